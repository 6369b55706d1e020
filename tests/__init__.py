"""matid's tests; they mirror the package (tests/rod/test_x.py for matid/rod/x.py)."""

from pathlib import Path

#: The repository root and the tests' folder (data/, corpus/).
ROOT = Path(__file__).resolve().parents[1]
TESTS = ROOT / "tests"
