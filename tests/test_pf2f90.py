#!/usr/bin/python3
"""Tests of tests/pf2f90.py (the .pf translator used when pFUnit is not
installed).  Run by `make test` as /usr/bin/python3 tests/test_pf2f90.py;
ends with the line "N passed, N failed" that tests/run_tests.sh adds up."""

import glob
import os
import re
import subprocess
import sys
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import pf2f90  # noqa: E402  (the module under test, next to this file)

SERIAL = """\
module test_x
  use funit
  use kinds, only: wp
  implicit none

contains

  @test
  subroutine adds_up()
    real(wp) :: a(2)
    a = [1.0_wp, 2.0_wp]
    @assertEqual(3.0_wp, sum(a), tolerance=0.0_wp, message='sum, (of) a')
    @assertTrue(size(a) == 2)
    @assertFalse(any(a < 0), message='none negative')
    @assertRelativelyEqual(2.0_wp, a(2), tolerance=1e-15_wp)
  end subroutine adds_up

  !> Comments between the directive and the subroutine are allowed.
  @test
  ! like this one
  subroutine second()
    @assertEqual(1, 1)
  end subroutine second

end module test_x
"""

MPI = """\
module test_y
  use funit
  use pfunit, only: MpiTestMethod
  implicit none

contains

  @before
  subroutine set_up(this)
    class(MpiTestMethod), intent(inout) :: this
  end subroutine set_up

  @after
  subroutine tear_down(this)
    class(MpiTestMethod), intent(inout) :: this
  end subroutine tear_down

  @mpitest(npes=[1, 3])
  subroutine on_ranks(this)
    class(MpiTestMethod), intent(inout) :: this
    @assertTrue(this%getNumProcesses() >= 1)
  end subroutine on_ranks

end module test_y
"""


def translate(text):
    """The translation of text, read from the file named after its module."""
    module = re.search(r'^module (\w+)', text, re.M).group(1)
    return pf2f90.translate('tests/unit/%s.pf' % module, text)


class Translation(unittest.TestCase):

    def test_directives_become_comments_and_calls(self):
        out = translate(SERIAL).splitlines()
        self.assertEqual(out[0], '#line 1 "tests/unit/test_x.pf"')
        self.assertIn('!  @test', out)
        self.assertIn("    call assertEqual(3.0_wp, sum(a), tolerance=0.0_wp, message='sum, (of) a', "
                      "location=SourceLocation('test_x.pf', 12))", out)
        self.assertIn("    call assertTrue(size(a) == 2, location=SourceLocation('test_x.pf', 13))", out)
        self.assertIn("    call assertFalse(any(a < 0), message='none negative', "
                      "location=SourceLocation('test_x.pf', 14))", out)
        self.assertIn("    call assertRelativelyEqual(2.0_wp, a(2), tolerance=1e-15_wp, "
                      "location=SourceLocation('test_x.pf', 15))", out)

    def test_use_funit_and_pfunit_become_use_testing(self):
        out = translate(MPI).splitlines()
        self.assertIn('  use testing', out)
        self.assertIn('  use testing, only: MpiTestMethod', out)
        self.assertFalse(any(re.search(r'\bp?funit\b', line) for line in out))

    def test_lines_keep_their_numbers(self):
        text = SERIAL
        out = translate(text).splitlines()[1:]
        for number, line in enumerate(text.splitlines()):
            if line.strip().startswith('@') or line.startswith('end module'):
                continue
            self.assertEqual(out[number], line.replace('use funit', 'use testing'),
                             'line %d' % (number + 1))

    def test_suite_runs_tests_in_file_order(self):
        out = translate(SERIAL)
        self.assertIn("""  subroutine test_x_suite()
    call run_test('test_x_suite', 'adds_up', adds_up)
    call run_test('test_x_suite', 'second', second)
  end subroutine test_x_suite
""", out)
        # the suite goes inside the module, and the line count resumes after it
        self.assertTrue(out.rstrip().endswith('#line 25 "tests/unit/test_x.pf"\nend module test_x'))

    def test_mpitest_one_instance_per_npes_with_fixtures(self):
        out = translate(MPI)
        calls = re.findall(r"call run_mpi_test\('test_y_suite', 'on_ranks', (\d), on_ranks, "
                           r"set_up=set_up, tear_down=tear_down\)", out)
        self.assertEqual(calls, ['1', '3'])
        self.assertNotIn('call run_test(', out)

    def test_serial_fixtures(self):
        text = SERIAL.replace('contains\n', 'contains\n\n  @before\n  subroutine prepare()\n'
                              '  end subroutine prepare\n', 1)
        out = translate(text)
        self.assertIn("call run_test('test_x_suite', 'adds_up', adds_up, set_up=prepare)", out)

    def test_long_assertion_is_wrapped_and_renumbered(self):
        long_message = "message='" + 'm' * 60 + "'"
        text = SERIAL.replace("message='none negative'", long_message)
        out = translate(text).splitlines()
        self.assertTrue(all(len(line) <= pf2f90.MAX_COLUMNS for line in out))
        k = next(i for i, line in enumerate(out) if 'call assertFalse' in line)
        self.assertTrue(out[k].endswith('&'))
        self.assertIn("location=SourceLocation('test_x.pf', 14))", out[k + 1])
        self.assertEqual(out[k + 2], '#line 15 "tests/unit/test_x.pf"')

    def test_commas_inside_brackets_and_strings(self):
        self.assertEqual(pf2f90.split_arguments("f(a, b), [1, 2], 'x, ''y''', c"),
                         ['f(a, b)', '[1, 2]', "'x, ''y'''", 'c'])
        self.assertEqual(pf2f90.split_arguments('"a, b" // "c", d(e(1, 2))'),
                         ['"a, b" // "c"', 'd(e(1, 2))'])
        self.assertIsNone(pf2f90.split_arguments('f(a, b'))
        self.assertIsNone(pf2f90.split_arguments("'open"))

    def test_comparisons_are_not_keywords(self):
        out = translate(SERIAL.replace('@assertTrue(size(a) == 2)', '@assertTrue(a(1) <= a(2))'))
        self.assertIn('call assertTrue(a(1) <= a(2), location=', out)


class Refusals(unittest.TestCase):
    """Anything outside the subset stops the translation with FILE:LINE."""

    def refused(self, text, line, words, path=None):
        if path is None:       # the file named after the module, as pFUnit wants
            path = 'tests/unit/%s.pf' % re.search(r'^module (\w+)', text, re.M).group(1)
        with self.assertRaises(pf2f90.TranslationError) as caught:
            pf2f90.translate(path, text)
        message = str(caught.exception)
        self.assertTrue(message.startswith('%s:%d: ' % (path, line)), message)
        self.assertIn(words, message)

    def test_other_directives(self):
        for directive in ['@assertLessThan(1, 2)', '@assertIsNaN(x)', '@disable',
                          '@testcase', '@testParameter', '@suite(name=x)']:
            self.refused(SERIAL.replace('@assertTrue(size(a) == 2)', directive), 13,
                         'construct not supported')

    def test_test_options(self):
        self.refused(SERIAL.replace('  @test\n  subroutine adds_up',
                                    '  @test(npes=[1])\n  subroutine adds_up'), 8,
                     'construct not supported')
        self.refused(MPI.replace('@mpitest(npes=[1, 3])', '@mpitest'), 18,
                     'construct not supported')
        self.refused(MPI.replace('@mpitest(npes=[1, 3])', '@mpitest(npes=[0])'), 18, 'N >= 1')

    def test_what_follows_a_directive(self):
        self.refused(SERIAL.replace('  subroutine adds_up()\n', '  integer :: i\n'), 9,
                     'must be followed by a subroutine')
        self.refused(SERIAL.replace('subroutine adds_up()', 'subroutine adds_up(this)'), 9,
                     'takes no arguments')
        self.refused(MPI.replace('subroutine on_ranks(this)', 'subroutine on_ranks()'), 19,
                     'takes one argument')

    def test_assertion_form(self):
        line = '@assertTrue(size(a) == 2)'
        cases = [('@assertTrue(size(a) == 2, &', 'cannot be continued'),
                 ('@assertTrue(size(a) == 2)  ! why', 'closing parenthesis'),
                 ('@assertEqual(3)', 'takes 2 positional arguments, not 1'),
                 ('@assertEqual(1, 2, 3)', 'takes 2 positional arguments, not 3'),
                 ('@assertEqual(1.0, 2.0, tol=0.1)', 'keyword tol= not supported'),
                 ("@assertEqual(1, message='m', 2)", 'positional argument after a keyword'),
                 ("@assertTrue(.true., message='a', message='b')", 'message= given twice'),
                 ('@assertRelativelyEqual(1.0, 2.0)', 'needs tolerance='),
                 ('@assertTrue()', 'cannot read its arguments'),
                 ('@assertTrue(f(a)', 'cannot read its arguments'),
                 ('@assertTrue(x) )', 'cannot read its arguments')]
        for directive, words in cases:
            self.refused(SERIAL.replace(line, directive), 13, words)

    def test_too_long_for_funitproc(self):
        self.refused(SERIAL.replace("message='none negative'", "message='" + 'n' * 100 + "'"), 14,
                     'funitproc would write a line of')

    def test_module_shape(self):
        self.refused(SERIAL, 1, 'named after the file', path='tests/unit/test_z.pf')
        self.refused(SERIAL.replace('  implicit none\n', '  implicit none\n  private\n'), 5,
                     'default private')
        text = SERIAL.replace('  @test\n', '').replace('  @assert', '  !')
        self.refused(text, len(text.splitlines()), 'no @test or @mpitest')
        self.refused(SERIAL.replace('  use funit\n', '  use, non_intrinsic :: funit\n'), 2,
                     'construct not supported')

    def test_private_inside_a_type_is_fine(self):
        text = SERIAL.replace('  implicit none\n', '  implicit none\n  type :: t\n'
                              '    private\n    integer :: i\n  end type t\n')
        self.assertIn('test_x_suite', translate(text))

    def test_fixture_rules(self):
        self.refused(MPI.replace('  @after\n', ''), 8, '@before without @after')
        mixed = MPI.replace('end module', '  @test\n  subroutine plain()\n  end subroutine plain\n\n'
                            'end module')
        self.refused(mixed, 8, 'both @test and @mpitest')
        self.refused(MPI.replace('subroutine set_up(this)', 'subroutine set_up()'), 8,
                     'one argument')


class CommandLine(unittest.TestCase):

    def run_script(self, text, name='test_x.pf'):
        with tempfile.TemporaryDirectory() as tmp:
            src = os.path.join(tmp, name)
            dst = os.path.join(tmp, 'out.F90')
            with open(src, 'w') as f:
                f.write(text)
            p = subprocess.run([sys.executable, os.path.join(HERE, 'pf2f90.py'), src, dst],
                               capture_output=True, text=True)
            made = os.listdir(tmp)
        return p, made

    def test_writes_the_output(self):
        p, made = self.run_script(SERIAL)
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertEqual(sorted(made), ['out.F90', 'test_x.pf'])

    def test_refusal_exits_1_and_writes_nothing(self):
        p, made = self.run_script(SERIAL.replace('@assertTrue(size(a) == 2)', '@assertAny(a)'))
        self.assertEqual(p.returncode, 1)
        self.assertRegex(p.stderr, r'test_x\.pf:13: construct not supported: @assertAny')
        self.assertEqual(made, ['test_x.pf'])


class TheSuite(unittest.TestCase):
    """Every tests/unit/*.pf translates, with each test registered."""

    def test_unit_suites(self):
        files = sorted(glob.glob(os.path.join(HERE, 'unit', 'test_*.pf')))
        self.assertTrue(files)
        for path in files:
            with open(path) as f:
                text = f.read()
            out = pf2f90.translate(path, text)
            tests = len(re.findall(r'^\s*@test\s*$', text, re.M))
            instances = sum(len(m.split(',')) for m in
                            re.findall(r'^\s*@mpitest\(npes=\[([0-9, ]+)\]\)', text, re.M))
            self.assertEqual(out.count('call run_test('), tests, path)
            self.assertEqual(out.count('call run_mpi_test('), instances, path)


class Summary(unittest.TextTestResult):
    """Counts passes for the closing line."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.passed = 0

    def addSuccess(self, test):
        super().addSuccess(test)
        self.passed += 1


if __name__ == '__main__':
    suite = unittest.defaultTestLoader.loadTestsFromModule(sys.modules[__name__])
    result = unittest.TextTestRunner(stream=sys.stdout, verbosity=2,
                                     resultclass=Summary).run(suite)
    failed = len(result.failures) + len(result.errors)
    print('%d passed, %d failed' % (result.passed, failed))
    sys.exit(1 if failed else 0)
