"""``manta-drake study validation``: each model of the package against its independent
reference (theory, a published data set, an independent code), one section of
``docs/validation.md`` per model.

The page holds one marked block per section (``<!-- section: NAME -->`` ...
``<!-- end section: NAME -->``); a section's study replaces its own block only, so the sections
are regenerated apart. ``SECTIONS`` names them: ``--section NAME`` runs one. Every section
takes the same folders (``add_folder_options``): ``--runs DIR`` for its work (its runs or
cached cases, ``DIR/STEM.json`` and ``DIR/STEM.md``; default ``out/validation/NAME``) and
``--out DIR`` for the page (``DIR/validation.md``; default the checkout's ``docs/``,
``studies.report.output_folder``). A section's reference file in ``models/reference/`` has
its own option, whose default is the checkout's file (``reference_file``).
"""

from __future__ import annotations

import importlib
import pathlib
import sys

from manta_drake.config_io import ScenarioError
from manta_drake.studies.options import StudyParser

# name -> (module with main(argv, prog) -> int, what it validates)
SECTIONS = {
    "released": (
        "manta_drake.studies.validation.released",
        "the simulator's effective heave mass and roll inertia, the robot released at "
        "rest under water, against the whole robot's BEM added mass",
    ),
    "added-mass": (
        "manta_drake.studies.validation.added_mass",
        "added mass of the hull, the fin plates and the robot against Lamb, strip "
        "theory, DNV-RP-H103 and capytaine (BEM); models/reference/added_mass_bem.yaml",
    ),
    "vortex-lattice": (
        "manta_drake.studies.validation.vortex_lattice",
        "the fin strips' thrust against pterasoftware (UVLM) and Garrick; "
        "models/reference/vortex_lattice.yaml",
    ),
    "foil-data": (
        "manta_drake.studies.validation.foil_data",
        "the fin strips' thrust and efficiency against a heaving-pitching foil "
        "experiment (MIT, h0/c 0.75, alpha_max 15 deg); "
        "models/reference/heaving_pitching_foil.yaml",
    ),
}
PAGE_TITLE = "Validation"
PAGE_COMMAND = "manta-drake study validation --section NAME"
PAGE = "validation.md"  # the page in the --out folder
RUNS = pathlib.Path("out/validation")  # the sections' work folders: RUNS/NAME
TEMPLATES = pathlib.Path(__file__).resolve().parent / "templates"


def template_env():
    """The sections' Jinja2 environment (their templates in ``TEMPLATES``) with the reports'
    number filters (``studies.report``)."""
    from manta_drake.studies.report import template_env as report_env

    return report_env(TEMPLATES)


def render_template(name: str, **context) -> str:
    """Template ``name`` of ``TEMPLATES`` rendered with ``context``."""
    return template_env().get_template(name).render(**context)


def round_floats(x, digits: int):
    """Floats (also nested in mappings, lists and arrays) to ``digits`` significant digits,
    numpy scalars to plain numbers: what the sections write into their result files."""
    import numpy as np

    if isinstance(x, dict):
        return {k: round_floats(v, digits) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [round_floats(v, digits) for v in x]
    if isinstance(x, np.ndarray):
        return round_floats(x.tolist(), digits)
    if isinstance(x, (float, np.floating)):
        return float(f"{float(x):.{digits}g}")
    if isinstance(x, np.integer):
        return int(x)
    return x


class ValidationError(ScenarioError):
    """A bad option, results or reference file of a validation section (one line, exit 2)."""


def add_folder_options(parser, section: str, runs_help: str) -> None:
    """A section's ``--runs DIR`` (what ``runs_help`` says it holds) and ``--out DIR`` (the
    page's folder)."""
    parser.add_argument(
        "--runs",
        metavar="DIR",
        default=str(RUNS / section),
        help=f"{runs_help} (default {RUNS / section})",
    )
    parser.add_argument(
        "--out",
        metavar="DIR",
        help=f"the page's folder: DIR/{PAGE}, whose {section} block is replaced (default the "
        "checkout's docs/)",
    )


def check_runs(runs) -> pathlib.Path:
    """A section's ``--runs``: a folder that can be written (or created)."""
    from manta_drake.config_io import check_writable_folder

    return check_writable_folder(runs, "--runs", example="out/validation", error=ValidationError)


def page_path(out, prog: str) -> pathlib.Path:
    """The page in the ``--out`` folder (the checkout's docs/ without one; refused from an
    installed package)."""
    from manta_drake.studies.report import output_folder

    return output_folder(out, prog) / PAGE


def reference_file(given, prog: str, option: str, name: str) -> str:
    """A reference file's option: ``given``, else the checkout's ``models/reference/NAME``
    (refused in one line naming ``option`` from an installed package)."""
    if given is not None:
        return given
    from manta_drake.studies.report import output_folder

    models = output_folder(None, prog, default="models", option=option)
    return str(models / "reference" / name)


def write_results(out, stem: str, results: dict, block: str) -> tuple[pathlib.Path, ...]:
    """A section's outputs in ``out``: STEM.json (its results) and STEM.md (its block)."""
    import json

    out = pathlib.Path(out)
    out.mkdir(parents=True, exist_ok=True)
    json_path, md_path = out / f"{stem}.json", out / f"{stem}.md"
    json_path.write_text(json.dumps(results, indent=1) + "\n")
    md_path.write_text(block + "\n")
    return json_path, md_path


def run_module(main) -> None:
    """The ``python -m`` entry of a section's module: its ``main``, a bad option as one line
    on stderr with exit status 2 (``manta-drake study validation`` does the same)."""
    try:
        sys.exit(main())
    except ScenarioError as e:
        print(f"error: {e}", file=sys.stderr)
        sys.exit(2)


def section_markers(name: str) -> tuple[str, str]:
    """The markers of section ``name``'s block in ``docs/validation.md``."""
    return f"<!-- section: {name} -->", f"<!-- end section: {name} -->"


def write_section(path, name: str, block: str) -> None:
    """Puts section ``name``'s ``block`` (its markers included) into the page ``path``: replaces
    the page's block of that name, or appends the block to a page that has none yet (a missing
    page is created with its title and stamp), so the sections can be written in any order."""
    import pathlib

    from manta_drake.studies.stamp import replace_marked_block, write_stamped

    path = pathlib.Path(path)
    begin, end = section_markers(name)
    if path.exists():
        text = path.read_text()
        if begin not in text and end not in text:
            write_stamped(path, text.rstrip("\n") + "\n\n" + block + "\n")
            return
    replace_marked_block(
        path, block, begin, end, new_page=(PAGE_TITLE, PAGE_COMMAND), what=f"the {name} section"
    )


def main(argv=None, prog=None) -> int:
    """``manta-drake study validation --section NAME [ARGS...]``: runs the section's study on
    ARGS (``--section NAME --help`` gives its options)."""
    prog = prog or "manta-drake study validation"
    argv = sys.argv[1:] if argv is None else list(argv)
    listing = "\n".join(f"  {name:<15} {text}" for name, (_, text) in SECTIONS.items())
    parser = StudyParser(
        prog=prog,
        add_help=False,
        description="Validates a model against its independent reference and "
        "writes its section of docs/validation.md.",
        epilog=f"sections:\n{listing}",
    )
    parser.add_argument("--section", metavar="NAME", help=f"one of {', '.join(SECTIONS)}")
    parser.add_argument(
        "-h",
        "--help",
        action="store_true",
        help="this help, or with --section the section's options",
    )
    args, rest = parser.parse_known_args(argv)
    if args.section is None:
        if args.help:
            import argparse

            parser.formatter_class = argparse.RawDescriptionHelpFormatter
            parser.print_help()
            return 0
        raise ScenarioError(f"{prog}: --section NAME is required (one of {', '.join(SECTIONS)})")
    if args.section not in SECTIONS:
        raise ScenarioError(
            f"{prog}: --section {args.section!r}: expected one of {', '.join(SECTIONS)}"
        )
    module = importlib.import_module(SECTIONS[args.section][0])
    return module.main(
        rest + (["--help"] if args.help else []), prog=f"{prog} --section {args.section}"
    )
