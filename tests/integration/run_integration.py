#!/usr/bin/python3
"""Runs the integration tests: every function test_* of every module
tests/integration/test_*.py, in file order.  A test fails by raising; the run
ends with the line "N passed, N failed" and a non-zero exit on any failure.
Run one module with: /usr/bin/python3 tests/integration/run_integration.py test_x
"""
import importlib
import pathlib
import sys
import time
import traceback

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))


def main(argv):
    names = argv[1:] or sorted(p.stem for p in HERE.glob("test_*.py"))
    passed = failed = 0
    for name in names:
        module = importlib.import_module(name)
        tests = [(k, v) for k, v in vars(module).items() if k.startswith("test_") and callable(v)]
        tests.sort(key=lambda kv: kv[1].__code__.co_firstlineno)
        for tname, fn in tests:
            t0 = time.time()
            try:
                fn()
            except Exception:  # a failed assertion or an unexpected error
                failed += 1
                print(f"[FAIL] {name}::{tname}")
                traceback.print_exc(file=sys.stdout)
            else:
                passed += 1
                print(f"[ OK ] {name}::{tname} ({time.time() - t0:.1f} s)")
            sys.stdout.flush()
    print(f"{passed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
