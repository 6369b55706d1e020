"""Write docs/scenes.md, the scene format's reference page, from matid/rod/schema.py.

    PYTHONPATH=$PWD python docs/make_scenes.py

tests/rod/test_scene_schema.py checks that the committed page is what this writes.
"""

from __future__ import annotations

from pathlib import Path

from matid.rod.scene_docs import reference

PAGE = Path(__file__).resolve().parent / "scenes.md"

if __name__ == "__main__":
    PAGE.write_text(reference(), encoding="utf-8")
    print(f"wrote {PAGE}")
