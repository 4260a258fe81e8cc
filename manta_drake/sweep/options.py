"""The options the many-run commands share: ``manta-drake sweep``, ``calibrate`` and
``optimize`` add them with :func:`add_many_run_options` and check them with
:func:`check_many_run_options`, before anything is loaded or simulated.

``--out DIR`` (required), the cluster's ``--scheduler``, ``--workers`` and ``--dashboard``
(``manta_drake.cluster.add_cluster_arguments``), ``--set KEY=VALUE`` (a command that layers
scenario overrides), ``--seed N`` (a command whose file has a seed) and ``--quiet``. A bad
value is one line naming the option and what is allowed (exit status 2).
"""

from __future__ import annotations

from manta_drake.cluster import add_cluster_arguments, check_cluster_arguments
from manta_drake.config_io import check_integer
from manta_drake.scenario import parse_set
from manta_drake.sweep.config import SweepError, check_out_folder

# The title of the shared options' group in each command's --help.
GROUP_TITLE = "options of every many-run command (sweep, calibrate, optimize)"
MAX_SEED = 2**32 - 1  # numpy's and CMA-ES's seeds are 32-bit


def add_many_run_options(
    parser,
    out_help: str = "output folder",
    set_help: str | None = None,
    seed_help: str | None = None,
) -> None:
    """Adds the shared options to a command's parser, in their own group of its --help.

    Args:
        parser: the command's ``argparse`` parser.
        out_help: what ``--out`` is (the output folder, and what a restart does there).
        set_help: what a ``--set KEY=VALUE`` override is layered on (e.g. "the file's
            `fixed` overrides"); None: the command has no ``--set``.
        seed_help: what ``--seed N`` seeds and replaces; None: the command has no ``--seed``.
    """
    group = parser.add_argument_group(GROUP_TITLE)
    group.add_argument("--out", required=True, help=out_help)
    add_cluster_arguments(group)
    if set_help is not None:
        group.add_argument(
            "--set",
            action="append",
            default=[],
            metavar="KEY=VALUE",
            help=f"override a scenario field, e.g. --set contact.friction=0.7, {set_help}; "
            "repeatable",
        )
    if seed_help is not None:
        group.add_argument("--seed", type=int, metavar="N", help=f"{seed_help}, 0 to {MAX_SEED}")
    group.add_argument("--quiet", action="store_true", help="no progress bar")


def check_many_run_options(args, outputs=(), inputs=(), folders=()) -> dict:
    """Checks the shared options before anything is loaded or simulated: the cluster's
    (``check_cluster_arguments``), ``--seed`` in [0, 2^32 - 1], ``--out`` (``check_out_folder``
    with the command's ``outputs``, ``inputs`` and ``folders``) and the ``--set`` overrides'
    form (``KEY=VALUE``; the values are checked against the scenario when it is loaded).

    Returns:
        the ``--set`` overrides, dotted key -> value (empty for a command without ``--set``).

    Raises:
        ScenarioError: one line naming the option (a ``ClusterError``, a ``SweepError``).
    """
    check_cluster_arguments(args)
    seed = getattr(args, "seed", None)
    if seed is not None:
        check_integer("--seed", seed, 0, MAX_SEED, error=SweepError)
    check_out_folder(args.out, outputs, inputs, folders)
    return parse_set(list(getattr(args, "set", None) or []))
