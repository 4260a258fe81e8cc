#!/usr/bin/env python3
"""Writes models/manta.sdf and models/pool.sdf from manta_drake/model/robot_params.py.

Usage: python scripts/generate_models.py [--check]
  --check  exit 1 if the committed files differ from what the parameters give.
"""

import argparse
import sys

from manta_drake.model import MODELS_DIR as MODELS
from manta_drake.model.model_sdf import pool_sdf, robot_sdf


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="only compare, do not write")
    args = parser.parse_args()
    stale = []
    for name, text in (("manta.sdf", robot_sdf()), ("pool.sdf", pool_sdf())):
        path = MODELS / name
        if args.check:
            if not path.exists() or path.read_text() != text:
                stale.append(name)
        else:
            path.write_text(text)
            print(f"wrote {path}")
    if stale:
        print(f"out of date: {', '.join(stale)}; run scripts/generate_models.py", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
