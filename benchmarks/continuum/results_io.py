"""Write one continuum run to results/<name>.json (shared by run_2d.py and run_3d.py)."""

from __future__ import annotations

import json
import platform
import time
from pathlib import Path

RESULTS = Path(__file__).parent / "results"


def save(name: str, out: dict, t0: float, threads: int = 2) -> None:
    """Add run time (since ``t0``) and machine to ``out``, make rows plain floats, write and print it."""
    out["runtime_s"] = time.time() - t0
    out["machine"] = {"platform": platform.platform(), "processor": platform.processor(), "threads": threads}
    out["rows"] = [{k: v if isinstance(v, list) else float(v) for k, v in r.items()} for r in out["rows"]]
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / f"{name}.json").write_text(json.dumps(out, indent=1))
    print(name, out["ccx_rc"], len(out["rows"]), f"{out['runtime_s']:.0f} s")
