"""Bakes this folder's two caches with Blender as a Python module (bpy 5.0.1 from PyPI,
CPython 3.11): the same smoke in a 2 x 2 x 3 domain centred at (1, -2, 1.5), resolution
32, an emitter near the domain's +x +y corner, frames 1..6, once with Adaptive Domain on
and once off (the domain of the Blender add-on's test, `blender/tests/smoke_domain.py`).

    python data/blender-adaptive/bake.py OUT_FOLDER

writes OUT_FOLDER/adaptive and OUT_FOLDER/fixed (each a whole Mantaflow cache: config,
data, ...); frames 1 and 6 of their data (and the adaptive cache's configurations) are
what this folder keeps.
"""

import os
import subprocess
import sys
from pathlib import Path

TESTS = Path(__file__).resolve().parents[2] / "blender" / "tests"

if __name__ == "__main__":
    if len(sys.argv) == 3:
        sys.path.insert(0, str(TESTS))
        import manta_fix

        manta_fix.apply()
        from smoke_domain import smoke_domain

        smoke_domain(Path(sys.argv[1]), adaptive=sys.argv[2] == "adaptive", resolution=32,
                     emitter=(1.6, -1.45, 0.5), radius=0.25)
        sys.stdout.flush()
        # Mantaflow aborts while Python shuts down; the cache is complete by then.
        os._exit(0)
    out = Path(sys.argv[1])
    for kind in ("adaptive", "fixed"):
        subprocess.run([sys.executable, __file__, str(out / kind), kind], check=True)
