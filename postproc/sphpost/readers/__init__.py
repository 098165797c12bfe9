"""sphpost.readers: the files of a run, one module per format.

  sph       our run directory: timeseries.csv, input.nml, the HDF5 snapshots
            (doc/reference/output.md), the solver's closing summary
  namelist  the input file (input.nml) as a dict
  series    which files of another code's output directory are its particle
            files, one per output time, and their format
  plain     the plain format: CSV or .npz, one row per particle
  vtk       VTK files (legacy, .vtu, .vtp) by VTK's own readers
  pysph     PySPH's dumps (.npz, .hdf5)

Each reader of particle files returns ({name: array}, time or None, point
coordinates or None); sphpost.foreign turns them into one canonical set.
"""
