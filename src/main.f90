program sph
  implicit none
  print '(a)', 'sph: under construction'
end program sph
