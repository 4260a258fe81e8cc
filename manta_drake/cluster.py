"""The one Dask cluster helper of every many-run command (sweep, calibrate, optimize, the
studies): ``--scheduler ADDRESS`` connects to a running cluster, ``--workers N`` starts a
``LocalCluster`` of N single-threaded worker processes, ``--workers 0`` runs in this
process without Dask."""

import contextlib
import dataclasses as dc
import os
import re

from manta_drake.config_io import ScenarioError, check_integer


class ClusterError(ScenarioError):
    """The cluster options or the cluster itself cannot run the work; one line says why."""


def default_workers() -> int:
    """Worker processes of a local cluster: the CPUs this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:
        return max(1, os.cpu_count() or 1)


# Dask's statistical profiler samples every worker's task thread every 10 ms, taking the
# GIL each time: it made a 6 s swim ~20 % slower (median of 9 runs alternated between fresh
# one-worker clusters: 2.04 s with it, 1.72 s without). A simulation steps Python systems
# thousands of times a second, so the profiler is off in the clusters these commands start
# and stopped on the workers of a cluster they connect to (the dashboard's profile page then
# stays empty).
_WORKER_CONFIG = {"distributed.worker.profile.enabled": False}


def _stop_worker_profiler(dask_worker) -> int:
    """Stops a running worker's profiler callbacks; returns how many were running."""
    stopped = 0
    for name in ("profile", "profile-cycle"):
        callback = dask_worker.periodic_callbacks.pop(name, None)
        if callback is not None:
            callback.stop()
            stopped += 1
    return stopped


# The most worker processes of a local cluster (--workers): more than any one machine's cores.
MAX_WORKERS = 256

# A local cluster listens on the loopback interface only: its scheduler, workers and
# dashboard have no authentication, so nothing beyond this machine may reach them unless
# the user asks (``--dashboard ADDRESS``).
LOCAL_HOST = "127.0.0.1"
DEFAULT_DASHBOARD = f"{LOCAL_HOST}:0"  # port 0: any free port (8787 may be another user's)


@contextlib.contextmanager
def dask_client(
    scheduler: str | None = None, workers: int | None = None, dashboard: str = DEFAULT_DASHBOARD
):
    """A ``distributed.Client``: connected to ``scheduler`` (an address such as
    ``tcp://host:8786``), or to a new LocalCluster of ``workers`` processes with one thread
    each (Drake runs are single-threaded and hold the GIL: processes, not threads, run them
    side by side), listening on 127.0.0.1 with its dashboard at ``dashboard`` (``host:port``;
    ``""``: none). Closed (and the local cluster shut down) on exit. The workers' profiler
    is off (see ``_WORKER_CONFIG``)."""
    import dask.config
    from distributed import Client, LocalCluster

    if scheduler:
        with Client(scheduler, timeout="30s") as client:
            check_workers(client)
            client.run(_stop_worker_profiler)
            yield client
        return
    # The nannies hand this configuration to the worker processes they start.
    with (
        dask.config.set(_WORKER_CONFIG),
        LocalCluster(
            n_workers=workers or default_workers(),
            threads_per_worker=1,
            processes=True,
            host=LOCAL_HOST,
            dashboard_address=dashboard or None,
        ) as cluster,
        Client(cluster) as client,
    ):
        yield client


def _worker_version() -> str:
    from manta_drake.version import __version__ as version  # the worker's own

    return version


def check_workers(client) -> None:
    """Raises ClusterError if the cluster has no workers or a worker lacks manta_drake."""
    try:
        versions = client.run(_worker_version)
    except ModuleNotFoundError as e:
        raise ClusterError(
            f"a Dask worker cannot import manta_drake ({e}); install this "
            "package (pip install -e .) in every worker's environment"
        ) from None
    if not versions:
        raise ClusterError("the Dask cluster has no workers; start some with `dask worker ADDRESS`")
    mine = _worker_version()
    other = {w: v for w, v in versions.items() if v != mine}
    if other:
        raise ClusterError(
            f"Dask workers run manta_drake {sorted(set(other.values()))}, this "
            f"client {mine}: install the same version everywhere"
        )


def add_cluster_arguments(parser) -> None:
    """``--scheduler``, ``--workers`` and ``--dashboard``, added to ``parser`` (a parser or an
    argument group): the many-run commands add them with their other shared options
    (``manta_drake.sweep.options``), the studies that run on Dask with theirs."""
    parser.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="a running Dask scheduler, e.g. tcp://host:8786 (default: a "
        "local cluster on this machine)",
    )
    parser.add_argument(
        "--workers",
        type=int,
        default=default_workers(),
        metavar="N",
        help="worker processes of the local cluster, 0 to "
        f"{MAX_WORKERS} (default: the CPU count, {default_workers()} here); 0: one run "
        "after another in this process, without Dask",
    )
    parser.add_argument(
        "--dashboard",
        default=DEFAULT_DASHBOARD,
        metavar="HOST:PORT",
        help="where the local cluster serves its Dask dashboard (default: "
        f"{DEFAULT_DASHBOARD}, this machine only, any free port; e.g. "
        "0.0.0.0:8787 to expose it, which has no authentication; '' for "
        "none)",
    )


def check_cluster_arguments(args) -> None:
    """Raises ClusterError for cluster arguments that cannot work (before any cluster or run
    starts)."""
    check_integer("--workers", args.workers, 0, MAX_WORKERS, error=ClusterError)
    scheduler = getattr(args, "scheduler", None)
    if scheduler is not None and not re.fullmatch(
        r"(tcp|tls|inproc|ucx|ws|wss)://\S+:\d+", scheduler
    ):
        raise ClusterError(
            f"--scheduler {scheduler!r}: expected an address such as tcp://HOST:8786"
        )
    dashboard = getattr(args, "dashboard", DEFAULT_DASHBOARD)
    if dashboard and not re.fullmatch(r"[^\s:]*:\d{1,5}", dashboard):
        raise ClusterError(
            f"--dashboard {dashboard!r}: expected HOST:PORT (e.g. "
            f"{DEFAULT_DASHBOARD}) or '' for none"
        )


def cluster_client(args):
    """What ``--scheduler`` / ``--workers`` ask for, as a context manager giving the client:
    a running scheduler, a new local cluster, or None (``--workers 0``: in this process)."""
    check_cluster_arguments(args)
    if args.scheduler or args.workers > 0:
        return dask_client(
            args.scheduler, args.workers, getattr(args, "dashboard", DEFAULT_DASHBOARD)
        )
    return contextlib.nullcontext()


# --- tasks a dead worker took with it ---------------------------------------------------------

# Exceptions of the cluster, not of a task: distributed raises them from a task's result when
# the worker running (or holding) the task died or the connection to it closed.
INFRASTRUCTURE_ERRORS = (
    "KilledWorker",
    "CommClosedError",
    "StreamClosedError",
    "FutureCancelledError",
    "CancelledError",
)
# Attempts of one task on the cluster before it counts as lost. Each attempt is itself
# rescheduled by distributed after a worker's death up to
# ``distributed.scheduler.allowed-failures`` times, so a task that kills every worker it
# starts on costs (1 + allowed-failures) x ATTEMPTS workers before it is given up.
ATTEMPTS = 3


def is_infrastructure_error(error) -> bool:
    """Whether an exception is the cluster's, not the task's: one of
    ``INFRASTRUCTURE_ERRORS`` or any ``OSError`` (distributed's connection errors are; the
    many-run commands' tasks return their own failures, never raise them). Given a reason
    ``"Name: text"`` of a record, only the names count."""
    if isinstance(error, str):
        return error.split(":", 1)[0].strip() in INFRASTRUCTURE_ERRORS
    return isinstance(error, OSError) or type(error).__name__ in INFRASTRUCTURE_ERRORS


@dc.dataclass(frozen=True)
class TaskFailure:
    """A task whose result was an exception on the client's side: the cluster's on every
    one of ``attempts`` (``lost``), or another one at once."""

    error: BaseException
    attempts: int
    lost: bool

    def reason(self) -> str:
        """One line: ``Name: text``, after ``lost to the cluster in N attempts: `` if lost."""
        text = f"{type(self.error).__name__}: {' '.join(str(self.error).split())}"
        return f"lost to the cluster in {self.attempts} attempts: {text}" if self.lost else text


def completed_resubmitting_lost(client, function, jobs, argument, key, window=None):
    """Runs ``function(argument(job))`` as one task per job and yields ``(job, outcome)`` as
    each finishes: the function's return, or a ``TaskFailure``. A task the cluster lost
    (``is_infrastructure_error``) is submitted again, up to ``ATTEMPTS`` times, each attempt
    with a key of its own (``key(job)`` + ``-aN``: the scheduler may still hold a lost
    attempt's key).

    Args:
        client: a ``distributed.Client``.
        function: what a task runs (picklable).
        jobs: an iterable of jobs, read as tasks are submitted.
        argument: job -> the task's argument.
        key: job -> the stem of its task keys.
        window: None: every job at once; else a callable giving the most tasks in flight
            (asked each time, since a cluster may gain workers).

    Tasks still running when the caller stops iterating (an interrupt) are cancelled.
    """
    from distributed import as_completed

    pending = as_completed()
    futures: dict = {}  # future -> (job, attempt)
    jobs = iter(jobs)
    none_left = object()

    def submit(job, attempt: int) -> None:
        future = client.submit(function, argument(job), pure=False, key=f"{key(job)}-a{attempt}")
        futures[future] = (job, attempt)
        pending.add(future)

    def fill() -> None:
        while window is None or len(futures) < window():
            job = next(jobs, none_left)
            if job is none_left:
                return
            submit(job, 1)

    try:
        fill()
        for future in pending:
            job, attempt = futures.pop(future)
            try:
                outcome = future.result()
            except Exception as e:  # noqa: BLE001 - the task's raise is its outcome
                outcome = e
            future.release()
            if isinstance(outcome, Exception):
                lost = is_infrastructure_error(outcome)
                if lost and attempt < ATTEMPTS:
                    submit(job, attempt + 1)  # a dead worker is not the task's failure
                    continue
                outcome = TaskFailure(outcome, attempt, lost)
            yield job, outcome
            fill()
    finally:
        if futures:  # stopped early: nothing of this call keeps running on the cluster
            client.cancel(list(futures))
