"""volpath/_core.pyi, the native module's type stub that mypy checks the public API against
(`make lint`), says what the built module holds: regenerated here and compared. A change to
the bindings takes the stub again and commits it:

    python tests/python/test_stubs.py --update      (or: make stubs)
"""

import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
STUB = os.path.join(ROOT, "volpath", "_core.pyi")


def generated():
    """The stub pybind11-stubgen writes for the installed volpath._core."""
    with tempfile.TemporaryDirectory() as out:
        subprocess.run(
            [sys.executable, "-m", "pybind11_stubgen", "volpath._core", "-o", out, "--exit-code"]
            + ["--enum-class-locations", "Tracer:volpath._core"],
            check=True,
            capture_output=True,
        )
        with open(os.path.join(out, "volpath", "_core.pyi"), encoding="utf-8") as f:
            stub = f.read()
    # pybind11-stubgen writes a native enum's members as `name: ClassVar[Tracer]`, which
    # type checkers take for an enum without members: given as `name = value`, they are.
    from volpath import _core

    for t in _core.Tracer:
        stub = stub.replace(f"    {t.name}: typing.ClassVar[Tracer]\n", f"    {t.name} = {t.value}\n")
    return stub


def test_stub_matches_the_built_module():
    with open(STUB, encoding="utf-8") as f:
        assert f.read() == generated(), "volpath/_core.pyi is out of date: run `make stubs`"


if __name__ == "__main__":
    if sys.argv[1:] != ["--update"]:
        sys.exit(__doc__)
    with open(STUB, "w", encoding="utf-8") as f:
        f.write(generated())
    print(f"wrote {STUB}")
