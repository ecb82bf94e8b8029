"""What the tests share: harnesses, independent checks, the SITL and browser helpers.
The test folders import it as ``helpers.NAME`` (tests/conftest.py puts ``tests/`` on the
path; the tools in ``tools/`` do the same)."""
