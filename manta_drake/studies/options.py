"""The checks of the studies' command lines.

Every option of ``manta-drake study NAME`` is checked, with its range, before the study starts
anything expensive (drawing, loading, simulating, rendering): a bad one raises a
``ScenarioError`` whose message is one line naming the option, the value and what is allowed,
which ``manta-drake`` prints on stderr with the exit status 2. The studies' parsers
(``StudyParser``) word their own errors (an unknown option, a value that is not a number) the
same way. A results table (a sweep's ``results.csv``) is checked by its header and its first
row only: bounded work whatever the file holds.
"""

from __future__ import annotations

import argparse
import csv
import os
import pathlib

from manta_drake.config_io import ScenarioError, check_writable_folder, short_repr

# A results table's header line is read up to this many characters (the sweeps' tables have
# about 50 columns of at most 40 characters each).
MAX_HEADER_CHARS = 65536
# An argparse message is cut to this many characters (it quotes the value it refuses).
MAX_MESSAGE_CHARS = 200


class StudyParser(argparse.ArgumentParser):
    """An ``ArgumentParser`` whose errors are one-line ``ScenarioError``s (no usage block, no
    ``SystemExit``), so ``manta-drake`` prints them as every other error; ``--help`` is
    unchanged."""

    def error(self, message: str):
        text = " ".join(message.split())  # argparse quotes the bad value: cut a long one
        if len(text) > MAX_MESSAGE_CHARS:
            text = text[: MAX_MESSAGE_CHARS - 3] + "..."
        raise ScenarioError(f"{self.prog}: {text} (see --help)")


def needs(option: str, given: bool, other: str, other_given: bool, why: str = "") -> None:
    """``option`` only means something together with ``other``: refused alone (``why``
    says what it does with it)."""
    if given and not other_given:
        raise ScenarioError(f"{option} needs {other}{': ' + why if why else ''}")


def check_names(option: str, text: str, allowed) -> list[str]:
    """The comma-separated names of ``text``, each one of ``allowed`` and none twice."""
    names = str(text).split(",")
    seen = set()
    for name in names:
        if name not in allowed:
            raise ScenarioError(f"{option}: {short_repr(name)} is not one of {', '.join(allowed)}")
        if name in seen:
            raise ScenarioError(f"{option}: {short_repr(name)} is given twice")
        seen.add(name)
    return names


def check_output_file(option: str, path, formats=None) -> pathlib.Path:
    """A file the study will write: not a folder, in a folder that can be written (or
    created); with ``formats`` (file name endings without the dot), ending in one of them."""
    if path is None or not str(path).strip():
        raise ScenarioError(f"{option}: an empty path; name the file to write")
    path = pathlib.Path(path)
    if path.is_dir():
        raise ScenarioError(f"{option} {path}: is a folder, not a file")
    if formats is not None and path.suffix.lower().lstrip(".") not in formats:
        raise ScenarioError(
            f"{option} {path}: the name must end in one of "
            f"{', '.join('.' + f for f in sorted(formats))}"
        )
    if path.exists() and not os.access(path, os.W_OK):
        raise ScenarioError(f"{option} {path}: cannot be written (no write permission)")
    check_writable_folder(path.parent, option=f"{option} {path}: the folder")
    return path


def figure_formats() -> set[str]:
    """The file name endings matplotlib writes figures in (png, svg, pdf, ...)."""
    from matplotlib.backend_bases import FigureCanvasBase

    return set(FigureCanvasBase.get_supported_filetypes())


def check_figure_file(option: str, path) -> pathlib.Path:
    """A figure the study will write (``check_output_file`` in a format matplotlib writes)."""
    return check_output_file(option, path, figure_formats())


def check_run_folders(option: str, out, folders, files=("log.npz", "metrics.json")) -> None:
    """``out/<folder>/<file>`` exists for every folder and file (runs to be reused)."""
    for folder in folders:
        for name in files:
            if not (pathlib.Path(out) / folder / name).is_file():
                raise ScenarioError(
                    f"{option} {out}: no {pathlib.Path(folder) / name} to "
                    "reuse; run the study without --reuse first"
                )


def _first_row(f) -> bool:
    """Whether the rest of the open table ``f`` holds a row (a line that is not empty);
    each line is read up to ``MAX_HEADER_CHARS`` characters."""
    while True:
        line = f.readline(MAX_HEADER_CHARS)
        if not line:
            return False
        if line.strip("\r\n"):
            return True


def check_results_csv(option: str, path, columns, hint: str = "") -> pathlib.Path:
    """A results table the study reads: a UTF-8 CSV file whose header names every one of
    ``columns`` and which has at least one row.

    Args:
        option: the option that names the file (``--results``).
        path: the file.
        columns: the columns the study reads.
        hint: added to the message of a missing file (how to make one).

    Raises:
        ScenarioError: one line naming the option, the file and what is wrong with it.
    """
    path = pathlib.Path(path)
    if path.is_dir():
        raise ScenarioError(f"{option} {path}: is a folder, not a results table (.csv)")
    if not path.is_file():
        raise ScenarioError(f"{option} {path}: file not found{hint}")
    try:
        with open(path, newline="", encoding="utf-8") as f:
            header = f.readline(MAX_HEADER_CHARS + 1)
            has_row = _first_row(f)
    except UnicodeDecodeError:
        raise ScenarioError(f"{option} {path}: not a UTF-8 text (CSV) file") from None
    except OSError as e:
        raise ScenarioError(f"{option} {path}: cannot be read ({e.strerror})") from None
    if len(header) > MAX_HEADER_CHARS:
        raise ScenarioError(
            f"{option} {path}: its first line is longer than "
            f"{MAX_HEADER_CHARS} characters: not a results table's header"
        )
    names = set(next(csv.reader([header]), []))
    if not header.strip():
        raise ScenarioError(
            f"{option} {path}: an empty file; expected a results table (a "
            "header of column names, then one row per run)"
        )
    missing = [c for c in columns if c not in names]
    if missing:
        raise ScenarioError(
            f"{option} {path}: no column{'s' if len(missing) > 1 else ''} "
            f"{', '.join(missing)} in its header"
        )
    if not has_row:
        raise ScenarioError(f"{option} {path}: a header but no rows (no run in the table)")
    return path


def check_sweep_results(path, columns, sweep: str, shipped) -> pathlib.Path:
    """``--results``: a sweep's results table (``check_results_csv``); a missing file's
    message says how to make it (``manta-drake sweep diagrams/sweeps/SWEEP.yaml``) or points
    to the shipped table ``shipped``."""
    return check_results_csv(
        "--results",
        path,
        columns,
        hint=f"; run `manta-drake sweep diagrams/sweeps/{sweep}.yaml --out "
        f"{pathlib.Path(path).parent}` or use --results {shipped}",
    )
