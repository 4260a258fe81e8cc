"""The studies that regenerate the reports of ``docs/``: ``manta-drake study NAME [ARGS...]``.

Each study is a module of this package with a ``main(argv, prog) -> int`` that parses its own
options (``manta-drake study NAME --help`` lists them) with ``options.StudyParser`` and checks
every one of them, with its range, before it starts anything expensive (``options`` has the
checks; a bad option is one line, exit status 2). They write into the source checkout
the package is imported from (``REPO``: its ``docs/``, ``docs/figures/`` and
``diagrams/sweeps/data/``), so they run from a checkout (an editable install).
"""

from __future__ import annotations

import argparse
import importlib
import pathlib

# The checkout whose reports the studies regenerate: the folder that holds the package.
REPO = pathlib.Path(__file__).resolve().parents[2]

# name -> (module, what it measures and where it writes)
STUDIES = {
    "faults": (
        "manta_drake.studies.faults",
        "random scenarios with faults (docs/fault_campaign.md)",
    ),
    "findings": (
        "manta_drake.studies.findings",
        "section 4.1's findings over the band (docs/findings.md)",
    ),
    "energy": (
        "manta_drake.studies.energy",
        "power, cost of transport and operation time over the band (docs/energy.md)",
    ),
    "transitions": (
        "manta_drake.studies.transitions",
        "transitions against baselines (docs/transitions.md)",
    ),
    "stance": (
        "manta_drake.studies.stance",
        "both gait readings on both fin sweeps (docs/stance.md)",
    ),
    "readings": (
        "manta_drake.studies.readings",
        "the gaits under readings of Eqs. (6)-(8) (docs/readings.md, quoted in docs/design.md)",
    ),
    "behaviours": (
        "manta_drake.studies.behaviours",
        "the heading hold and four_behaviors against the paper's runs (docs/behaviours.md)",
    ),
    "wall-noise": (
        "manta_drake.studies.wall_noise",
        "s_hat against depth noise (docs/figures/s_hat_vs_noise.png)",
    ),
    "cfd": (
        "manta_drake.studies.cfd",
        "the hull's damping by OpenFOAM, the paper's section 2.3 (docs/cfd.md, models/cfd/)",
    ),
    "validation": (
        "manta_drake.studies.validation",
        "each model against its independent reference, one --section at a time "
        "(docs/validation.md, models/reference/)",
    ),
}


def add_study_parser(subparsers) -> None:
    """Adds ``study NAME [ARGS...]`` to the ``manta-drake`` command line."""
    listing = "\n".join(f"  {name:<12} {text}" for name, (_, text) in STUDIES.items())
    parser = subparsers.add_parser(
        "study",
        help="run a study that regenerates a report of docs/",
        description="Runs a study that regenerates a report of docs/.",
        epilog=f"studies:\n{listing}\n\n`manta-drake study NAME --help` gives a study's options.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "study", choices=list(STUDIES), metavar="NAME", help=f"one of {', '.join(STUDIES)}"
    )
    # Everything after NAME is the study's own command line (its --help included).
    parser.add_argument(
        "study_args", nargs=argparse.REMAINDER, metavar="ARGS", help="the study's options"
    )


def study_main(args) -> int:
    """Runs the study ``args.study`` on ``args.study_args``; returns its exit status."""
    module = importlib.import_module(STUDIES[args.study][0])
    return module.main(args.study_args, prog=f"manta-drake study {args.study}")
