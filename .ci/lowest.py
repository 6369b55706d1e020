"""Print pip constraints pinning every dependency of pyproject.toml to its lower bound.

CI installs matid against these (``pip install -c``) so that each ``>=`` in pyproject is a
version that was installed and tested, not a guess. Usage: ``python .ci/lowest.py [extra ...]``.
"""

import re
import sys
import tomllib
from pathlib import Path

project = tomllib.loads((Path(__file__).resolve().parents[1] / "pyproject.toml").read_text())["project"]
requirements = list(project["dependencies"])
for extra in sys.argv[1:]:
    requirements += project["optional-dependencies"][extra]
for requirement in requirements:
    match = re.fullmatch(r"\s*([A-Za-z0-9_.\-]+)(\[[^\]]*\])?\s*>=\s*([0-9][^,;\s]*)\s*", requirement)
    if match is None:
        sys.exit(f"no lower bound to pin in {requirement!r}: write it as name>=version")
    print(f"{match.group(1)}=={match.group(3)}")
