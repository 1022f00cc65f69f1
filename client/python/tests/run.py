#!/usr/bin/python3
"""run.py - runs the qmcd package's tests (every tests/test_*.py) and
prints one line per test, "ok NAME" or "FAIL NAME: why", the lines
tests/e2e/lib.sh's tally counts.  With QMCD_TEST_REQUIRE=1 (as the e2e
script sets it) a skipped test is a failure: under `make check` every
test must run.  Exit status 0 only if nothing failed.

    run.py [PATTERN]     (unittest -k PATTERN)
"""
import io
import os
import sys
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.dirname(HERE))
REQUIRE = os.environ.get("QMCD_TEST_REQUIRE") == "1"


def one_line(text):
    lines = [x for x in text.strip().splitlines() if x.strip()]
    return (lines[-1] if lines else text)[:400]


class LineResult(unittest.TextTestResult):
    def addSuccess(self, test):
        super().addSuccess(test)
        print("ok %s" % test.id(), flush=True)

    def addFailure(self, test, err):
        super().addFailure(test, err)
        print("FAIL %s: %s" % (test.id(), one_line(self._exc_info_to_string(err, test))),
              flush=True)

    def addError(self, test, err):
        super().addError(test, err)
        print("FAIL %s: %s" % (test.id(), one_line(self._exc_info_to_string(err, test))),
              flush=True)

    def addSkip(self, test, reason):
        super().addSkip(test, reason)
        print("%s %s: skipped: %s" % ("FAIL" if REQUIRE else "skip", test.id(), reason),
              flush=True)

    def addSubTest(self, test, subtest, err):
        super().addSubTest(test, subtest, err)
        if err is not None:
            print("FAIL %s: %s" % (subtest.id(), one_line(self._exc_info_to_string(err, test))),
                  flush=True)


def main():
    loader = unittest.TestLoader()
    if len(sys.argv) > 1:
        loader.testNamePatterns = ["*%s*" % sys.argv[1]]
    suite = loader.discover(HERE, pattern="test_*.py", top_level_dir=HERE)
    runner = unittest.TextTestRunner(stream=io.StringIO(), resultclass=LineResult, verbosity=0)
    result = runner.run(suite)
    bad = len(result.failures) + len(result.errors) + (len(result.skipped) if REQUIRE else 0)
    print("%d run, %d failed or errored, %d skipped"
          % (result.testsRun, len(result.failures) + len(result.errors), len(result.skipped)))
    sys.exit(1 if bad or not result.testsRun else 0)


if __name__ == "__main__":
    main()
