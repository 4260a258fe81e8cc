"""Nothing listens beyond this machine unless the user asks: a run's Meshcat, a sweep's
local Dask cluster (scheduler, workers, dashboard) and the seam's LCM default stay on the
loopback interface."""

import ipaddress
import os

import psutil
import pytest

from manta_drake.cluster import DEFAULT_DASHBOARD, dask_client


def _listening(pids) -> list:
    out = []
    for pid in pids:
        for conn in psutil.Process(pid).net_connections(kind="inet"):
            if conn.status == psutil.CONN_LISTEN:
                out.append((pid, conn.laddr.ip, conn.laddr.port))
    return out


def _tree() -> list[int]:
    me = psutil.Process()
    return [me.pid] + [p.pid for p in me.children(recursive=True)]


@pytest.mark.slow
def test_a_local_cluster_listens_on_loopback_only():
    before = set(_listening([os.getpid()]))
    with dask_client(workers=1) as client:
        sockets = [s for s in _listening(_tree()) if s not in before]
        link = client.dashboard_link
    # The scheduler, the worker, its nanny and the dashboard: at least four listeners.
    assert len(sockets) >= 4, sockets
    for pid, ip, port in sockets:
        assert ipaddress.ip_address(ip).is_loopback, (pid, ip, port)
    assert link.startswith("http://127.0.0.1:")
    assert DEFAULT_DASHBOARD.startswith("127.0.0.1:")


def test_a_run_with_meshcat_listens_on_loopback_only():
    from manta_drake.scenario import load_scenario
    from manta_drake.wiring.diagram import build_diagram

    before = set(_listening([os.getpid()]))
    s = load_scenario("stand", overrides={"duration": 0.1})
    assert s.visualization.meshcat
    _, handles = build_diagram(s)
    sockets = [x for x in _listening([os.getpid()]) if x not in before]
    assert sockets, "Meshcat should serve its page"
    for pid, ip, port in sockets:
        assert ipaddress.ip_address(ip).is_loopback, (pid, ip, port)
    assert "localhost" in handles.meshcat.web_url() or "127.0.0.1" in handles.meshcat.web_url()


def test_the_seams_default_lcm_url_stays_on_this_machine():
    """LCM's UDP multicast with ttl=0: packets never leave the host."""
    from urllib.parse import parse_qs, urlparse

    from manta_drake.lcm_seam import DEFAULT_URL

    url = urlparse(DEFAULT_URL)
    assert url.scheme == "udpm"
    assert ipaddress.ip_address(url.hostname).is_multicast
    assert parse_qs(url.query)["ttl"] == ["0"]
