#!/usr/bin/python3
"""Translate a pFUnit test file (.pf) into Fortran for tests/testing.f90.

    /usr/bin/python3 tests/pf2f90.py tests/unit/test_eos.pf build/.../test_eos.F90

`make test` uses it when pFUnit is not installed (doc/developer/testing.md, "Unit tests"); with
pFUnit, pFUnit's own funitproc reads the same files.  It understands the part
of pFUnit's test language the suite uses, written as funitproc needs it
(one directive per line, no continuation, no trailing comment):

    use funit / use pfunit [, only: ...]   -> use testing [, only: ...]
    @test                    then  subroutine NAME()
    @mpitest(npes=[N, ...])  then  subroutine NAME(this)
    @before / @after         then  subroutine NAME() (NAME(this) in MPI suites)
    @assertTrue(condition [, message=...])
    @assertFalse(condition [, message=...])
    @assertEqual(expected, actual [, tolerance=...] [, message=...])
    @assertRelativelyEqual(expected, actual, tolerance=... [, message=...])

Anything else that starts with '@' is refused with "FILE:LINE: ..." and exit
status 1, as are the forms funitproc would mistranslate or that pFUnit would
not compile (a default `private`, @before without @after in an MPI suite).
Assertions get location=SourceLocation(file, line), as funitproc adds; the
module gets a subroutine <module>_suite() that runs its tests in file order
(the name of funitproc's suite function).  The output starts with a #line
directive, so compiler messages point into the .pf file.
"""

import os
import re
import sys

MAX_COLUMNS = 132   # free-form Fortran's line length

# directive (any case) -> (the harness's name, positional arguments,
# allowed keywords, required keywords)
ASSERTIONS = {
    'asserttrue': ('assertTrue', 1, {'message'}, set()),
    'assertfalse': ('assertFalse', 1, {'message'}, set()),
    'assertequal': ('assertEqual', 2, {'tolerance', 'message'}, set()),
    'assertrelativelyequal': ('assertRelativelyEqual', 2, {'tolerance', 'message'},
                              {'tolerance'}),
}

RE_MODULE = re.compile(r'\s*module\s+(\w+)\s*(!.*)?$', re.I)
RE_END_MODULE = re.compile(r'\s*end\s*module\b', re.I)
RE_CONTAINS = re.compile(r'\s*contains\s*(!.*)?$', re.I)
RE_PRIVATE = re.compile(r'\s*private\s*(!.*)?$', re.I)
RE_TYPE_START = re.compile(r'\s*type\s*((,[^:]*)?::\s*|\s)\w+\s*(!.*)?$', re.I)
RE_TYPE_END = re.compile(r'\s*end\s*type\b', re.I)
RE_USE_FUNIT = re.compile(r'(\s*use\s+)(p?funit)\b(.*)$', re.I)
RE_MENTIONS_FUNIT = re.compile(r'\s*use\b.*\bp?funit\b', re.I)
RE_SUBROUTINE = re.compile(r'\s*subroutine\s+(\w+)\s*(\(([^)]*)\))?\s*(!.*)?$', re.I)
RE_TEST = re.compile(r'\s*@test\s*$', re.I)
RE_MPITEST = re.compile(r'\s*@mpitest\s*\(\s*npes\s*=\s*\[([0-9,\s]+)\]\s*\)\s*$', re.I)
RE_FIXTURE = re.compile(r'\s*@(before|after)\s*$', re.I)
RE_ASSERT = re.compile(r'(\s*)@(\w+)\s*\((.*)\)\s*$')
RE_KEYWORD = re.compile(r'\s*(\w+)\s*=(?!=)(.*)$', re.S)


class TranslationError(Exception):
    """A construct outside the supported subset; str() is FILE:LINE: text."""


def split_arguments(text):
    """Split an argument list at its top-level commas (not inside
    parentheses, brackets or character literals)."""
    args, depth, quote, start = [], 0, None, 0
    for i, c in enumerate(text):
        if quote:
            if c == quote:
                quote = None          # a doubled quote closes and reopens
        elif c in '\'"':
            quote = c
        elif c in '([':
            depth += 1
        elif c in ')]':
            depth -= 1
            if depth < 0:
                return None
        elif c == ',' and depth == 0:
            args.append(text[start:i])
            start = i + 1
    if quote or depth != 0:
        return None
    args.append(text[start:])
    return [a.strip() for a in args]


def wrap_call(indent, head, args):
    """`call head(args)` on one line, or over several with '&' when it is
    longer than MAX_COLUMNS; None if an argument alone does not fit."""
    one = indent + head + '(' + ', '.join(args) + ')'
    if len(one) <= MAX_COLUMNS:
        return [one]
    lines, current = [], indent + head + '('
    follow = indent + ' ' * (len(head) + 1)
    for k, a in enumerate(args):
        piece = a + (')' if k == len(args) - 1 else ',')
        if current.strip() and not current.endswith('(') and \
                len(current) + 1 + len(piece) + 2 > MAX_COLUMNS:
            lines.append(current + ' &')
            current = follow + piece
        else:
            current += ('' if current.endswith('(') else ' ') + piece
    lines.append(current)
    if any(len(line) > MAX_COLUMNS for line in lines):
        return None
    return lines


class Translator:
    def __init__(self, path, text):
        self.path = path
        self.name = os.path.basename(path)
        self.lines = text.splitlines()
        self.tests = []            # (kind, name, npes) in file order
        self.fixtures = {}         # 'before'/'after' -> (name, has_arg, line)
        self.module = None

    def fail(self, lineno, message):
        raise TranslationError('%s:%d: %s' % (self.path, lineno, message))

    def next_subroutine(self, index, directive):
        """The subroutine statement after a directive (comments and blank
        lines between are allowed, as funitproc allows them)."""
        for j in range(index + 1, len(self.lines)):
            line = self.lines[j]
            if not line.strip() or line.strip().startswith('!'):
                continue
            m = RE_SUBROUTINE.match(line)
            if not m:
                self.fail(j + 1, '%s must be followed by a subroutine statement' % directive)
            args = [a.strip() for a in (m.group(3) or '').split(',') if a.strip()]
            return m.group(1), args, j + 1
        self.fail(index + 1, '%s at the end of the file' % directive)

    def assertion(self, lineno, m):
        indent, directive, body = m.group(1), m.group(2), m.group(3)
        key = directive.lower()
        if key not in ASSERTIONS:
            self.fail(lineno, 'construct not supported: @%s' % directive)
        call, npos, allowed, required = ASSERTIONS[key]
        # funitproc copies the arguments onto one line of its output
        width = len('  call %s(%s, &' % (call, body))
        if width > MAX_COLUMNS:
            self.fail(lineno, '@%s is too long: funitproc would write a line of %d columns '
                              '(at most %d)' % (directive, width, MAX_COLUMNS))
        args = split_arguments(body)
        if args is None or (len(args) == 1 and not args[0]):
            self.fail(lineno, '@%s: cannot read its arguments' % directive)
        positional, keywords = [], {}
        for a in args:
            k = RE_KEYWORD.match(a)
            if k:
                word = k.group(1).lower()
                if word not in allowed:
                    self.fail(lineno, '@%s: keyword %s= not supported (allowed: %s)'
                              % (directive, k.group(1), ', '.join(sorted(allowed))))
                if word in keywords:
                    self.fail(lineno, '@%s: %s= given twice' % (directive, word))
                keywords[word] = k.group(2).strip()
            elif keywords:
                self.fail(lineno, '@%s: a positional argument after a keyword one'
                          % directive)
            else:
                positional.append(a)
        if len(positional) != npos:
            self.fail(lineno, '@%s takes %d positional argument%s, not %d'
                      % (directive, npos, '' if npos == 1 else 's', len(positional)))
        for word in sorted(required - set(keywords)):
            self.fail(lineno, '@%s needs %s=' % (directive, word))
        out = positional + ['%s=%s' % (w, keywords[w]) for w in ('tolerance', 'message')
                            if w in keywords]
        out.append("location=SourceLocation('%s', %d)" % (self.name, lineno))
        wrapped = wrap_call(indent, 'call ' + call, out)
        if wrapped is None:
            self.fail(lineno, '@%s: an argument is too long for one line' % directive)
        return wrapped

    def translate(self):
        out = ['#line 1 "%s"' % self.path]
        end_module = None
        has_contains = False
        in_spec = in_type = False
        end_module_line = 0
        previous = ''
        for i, line in enumerate(self.lines):
            lineno = i + 1
            stripped = line.strip()
            if stripped.startswith('@'):
                if previous.rstrip().endswith('&') or stripped.endswith('&'):
                    self.fail(lineno, 'a directive cannot be continued over lines '
                                      '(funitproc reads one line)')
                if RE_TEST.match(line):
                    name, args, at = self.next_subroutine(i, '@test')
                    if args:
                        self.fail(at, '@test subroutine %s takes no arguments' % name)
                    self.tests.append(('test', name, None))
                    out.append('!' + line)
                elif RE_MPITEST.match(line):
                    npes = [int(n) for n in RE_MPITEST.match(line).group(1).split(',')
                            if n.strip()]
                    if not npes or min(npes) < 1:
                        self.fail(lineno, '@mpitest needs npes=[N, ...] with N >= 1')
                    name, args, at = self.next_subroutine(i, '@mpitest')
                    if len(args) != 1:
                        self.fail(at, '@mpitest subroutine %s takes one argument, '
                                      'class(MpiTestMethod)' % name)
                    self.tests.append(('mpitest', name, npes))
                    out.append('!' + line)
                elif RE_FIXTURE.match(line):
                    which = RE_FIXTURE.match(line).group(1).lower()
                    if which in self.fixtures:
                        self.fail(lineno, 'a second @%s' % which)
                    name, args, _ = self.next_subroutine(i, '@' + which)
                    if len(args) > 1:
                        self.fail(lineno, '@%s subroutine %s takes at most one argument'
                                  % (which, name))
                    self.fixtures[which] = (name, bool(args), lineno)
                    out.append('!' + line)
                elif stripped.lower().startswith(('@test', '@mpitest')):
                    self.fail(lineno, 'construct not supported: %s (only @test, and '
                                      '@mpitest(npes=[...]))' % stripped)
                else:
                    m = RE_ASSERT.match(line)
                    if not m:
                        word = re.match(r'@\w*', stripped).group(0)
                        if word[1:].lower() in ASSERTIONS:
                            self.fail(lineno, '%s must end with its closing parenthesis '
                                              '(funitproc reads one line: no comment after '
                                              'it)' % word)
                        self.fail(lineno, 'construct not supported: %s' % word)
                    wrapped = self.assertion(lineno, m)
                    out.extend(wrapped)
                    if len(wrapped) > 1:
                        out.append('#line %d "%s"' % (lineno + 1, self.path))
                previous = line
                continue
            m = RE_MODULE.match(line)
            if m and m.group(1).lower() != 'procedure':
                if self.module:
                    self.fail(lineno, 'a second module (one module per .pf file)')
                self.module = m.group(1)
                stem = os.path.splitext(self.name)[0]
                if self.module.lower() != stem.lower():
                    self.fail(lineno, 'module %s in file %s: pFUnit wants the module '
                                      'named after the file' % (self.module, self.name))
                in_spec = True
            elif RE_CONTAINS.match(line) and in_spec:
                has_contains = True
                in_spec = False
            elif RE_PRIVATE.match(line) and in_spec and not in_type:
                self.fail(lineno, 'a default private: pFUnit needs the tests public')
            elif RE_TYPE_START.match(line) and in_spec:
                in_type = True
            elif RE_TYPE_END.match(line):
                in_type = False
            elif RE_END_MODULE.match(line):
                end_module, end_module_line = len(out), lineno
            m = RE_USE_FUNIT.match(line)
            if m:
                rest = m.group(3)
                if rest.strip() and not re.match(r'\s*,\s*only\s*:', rest, re.I):
                    self.fail(lineno, 'construct not supported: %s' % stripped)
                line = m.group(1) + 'testing' + rest
            elif RE_MENTIONS_FUNIT.match(line):
                self.fail(lineno, 'construct not supported: %s (use funit or use pfunit)'
                          % stripped)
            out.append(line)
            previous = line
        if not self.module:
            self.fail(1, 'no module statement')
        if end_module is None or not has_contains:
            self.fail(len(self.lines), 'the module needs contains and end module')
        if not self.tests:
            self.fail(len(self.lines), 'no @test or @mpitest')
        self.check_fixtures()
        # the suite goes before `end module`; line numbers then resume
        out[end_module:end_module] = self.suite_lines() + [
            '#line %d "%s"' % (end_module_line, self.path)]
        return '\n'.join(out) + '\n'

    def check_fixtures(self):
        kinds = {kind for kind, _, _ in self.tests}
        mpi = 'mpitest' in kinds
        for which, (name, has_arg, lineno) in self.fixtures.items():
            if mpi and 'test' in kinds:
                self.fail(lineno, '@%s in a file with both @test and @mpitest: pFUnit '
                                  'calls it with different arguments' % which)
            if has_arg != mpi:
                self.fail(lineno, '@%s subroutine %s: %s' % (
                    which, name, 'one argument, class(MpiTestMethod)' if mpi
                    else 'no arguments'))
        if mpi and len(self.fixtures) == 1:
            which = list(self.fixtures)[0]
            self.fail(self.fixtures[which][2], '@%s without @%s: pFUnit builds @mpitest '
                      'fixtures from both' % (which, 'after' if which == 'before'
                                              else 'before'))

    def suite_lines(self):
        suite = self.module + '_suite'
        extra = ''
        if 'before' in self.fixtures:
            extra += ', set_up=' + self.fixtures['before'][0]
        if 'after' in self.fixtures:
            extra += ', tear_down=' + self.fixtures['after'][0]
        lines = ['', '  ! Written by tests/pf2f90.py: the tests in file order.',
                 '  subroutine %s()' % suite]
        for kind, name, npes in self.tests:
            if kind == 'test':
                calls = [("call run_test('%s', '%s', %s%s)" % (suite, name, name, extra))]
            else:
                calls = [("call run_mpi_test('%s', '%s', %d, %s%s)"
                          % (suite, name, n, name, extra)) for n in npes]
            for c in calls:
                lines.extend(wrap_call('    ', c.split('(')[0], split_arguments(
                    c[c.index('(') + 1:-1])))
        lines.append('  end subroutine %s' % suite)
        lines.append('')
        return lines


def translate(path, text):
    """The Fortran for the .pf text read from path (raises TranslationError)."""
    return Translator(path, text).translate()


def main(argv):
    if len(argv) != 3:
        sys.stderr.write('usage: pf2f90.py INPUT.pf OUTPUT.F90\n')
        return 2
    with open(argv[1]) as f:
        text = f.read()
    try:
        fortran = translate(argv[1], text)
    except TranslationError as e:
        sys.stderr.write('%s\n' % e)
        return 1
    tmp = argv[2] + '.tmp'
    with open(tmp, 'w') as f:
        f.write(fortran)
    os.replace(tmp, argv[2])
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv))
