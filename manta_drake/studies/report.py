"""Where a study writes its report and how the report's prose is kept: the two things every
study shares.

A study writes its pages into the folder it is told (``--out DIR``). Without ``--out`` it
rewrites the reports of the source checkout it runs from (``DIR`` defaults to the checkout's
``docs/``; pages go to ``DIR/NAME.md``, figures to ``DIR/figures/``). An installed package
has no checkout and no ``docs/``, so there ``--out`` is required and its absence is refused
in one line before anything runs.

The pages' prose is Jinja2 templates (``templates/NAME.md.j2`` beside the study modules),
rendered with ``StrictUndefined`` (a name the study does not give fails, it never prints as
empty) and the number filters the reports share:

- ``g(d=4)``: ``d`` significant digits; ``f(d=3)``: ``d`` decimals; ``signed(d=3)``: ``d``
  decimals with a sign; ``pct(d=2)``: a ratio as a signed percentage. None shows as ``-``.
"""

from __future__ import annotations

import pathlib

from manta_drake.config_io import ScenarioError, check_writable_folder
from manta_drake.studies import REPO

TEMPLATES = pathlib.Path(__file__).resolve().parent / "templates"


def checkout() -> pathlib.Path | None:
    """The source checkout the package is imported from (the folder that holds it, with its
    ``pyproject.toml`` and git metadata), or None for an installed package."""
    if (REPO / "pyproject.toml").is_file() and (REPO / ".git").exists():
        return REPO
    return None


def output_folder(out, prog: str, default: str = "docs", option: str = "--out DIR") -> pathlib.Path:
    """The folder a study writes into: ``out`` when given (checked writable), else the
    checkout's ``default`` folder. ``option`` is the option that names it in the message of
    an installed package (a data file's own option, with ``default="models"``, say).

    Raises:
        ScenarioError: no ``out`` and no checkout (an installed package), or ``out`` cannot
            be written; one line naming the option.
    """
    if out is not None:
        return check_writable_folder(out, option.split()[0], example="out/report")
    root = checkout()
    if root is None:
        raise ScenarioError(
            f"{prog}: {option} is required: this manta_drake is installed "
            f"({REPO / 'manta_drake'}), not a source checkout whose {default}/ the study "
            "could rewrite"
        )
    return root / default


def _number(spec: str, default: int):
    def fmt(x, digits: int = default) -> str:
        return "-" if x is None else format(float(x), spec.format(digits))

    return fmt


def template_env(folder: pathlib.Path = TEMPLATES):
    """The Jinja2 environment of the templates in ``folder``, with the shared filters."""
    import jinja2

    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(folder)),
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
        trim_blocks=True,
        lstrip_blocks=True,
    )
    env.filters["g"] = _number(".{}g", 4)
    env.filters["f"] = _number(".{}f", 3)
    env.filters["signed"] = _number("+.{}f", 3)
    env.filters["pct"] = lambda x, d=2: "-" if x is None else f"{100.0 * float(x):+.{d}f} %"
    return env


def render(name: str, folder: pathlib.Path = TEMPLATES, **context) -> str:
    """Template ``name`` of ``folder`` rendered with ``context``."""
    return template_env(folder).get_template(name).render(**context)
