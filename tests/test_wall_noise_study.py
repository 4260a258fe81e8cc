"""The wall-noise study's table and where it writes its figure
(manta_drake.studies.wall_noise), on a synthetic table of s_hat samples."""

import numpy as np

from manta_drake.studies import wall_noise


def _table():
    """s_hat 1 for every seed at every wall distance but the farthest, 0 there; at the
    nearest wall the second seed drops to 0.5 from the second noise level on."""
    table = {}
    for d in wall_noise.DISTANCES:
        level = 0.0 if d == max(wall_noise.DISTANCES) else 1.0
        table[d] = [np.array([level, level]) for _ in wall_noise.NOISE_MM]
    for samples in table[min(wall_noise.DISTANCES)][1:]:
        samples[1] = 0.5
    return table


def test_the_table_gives_mean_and_range_per_noise_and_distance(capsys):
    wall_noise.print_table(_table())
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 1 + len(wall_noise.NOISE_MM)
    assert wall_noise.DISTANCES == (0.4, 0.5, 0.6, 0.7, 0.75, 1.0)
    assert lines[0] == (
        " noise mm          d=0.4 m          d=0.5 m          d=0.6 m          d=0.7 m"
        "         d=0.75 m          d=1.0 m"
    )
    assert lines[1] == "      0.0 " + " ".join(
        ["   1.00 [1.00,1.00]"] * (len(wall_noise.DISTANCES) - 1) + ["   0.00 [0.00,0.00]"]
    )
    assert lines[2].startswith("      2.5    0.75 [0.50,1.00]    1.00 [1.00,1.00]")


def test_out_puts_the_figure_under_figures(tmp_path, monkeypatch, capsys):
    """The frames are not rendered here: the measured table is the synthetic one."""
    seeds = []
    monkeypatch.setattr(wall_noise, "measure", lambda n: seeds.append(n) or _table())
    assert wall_noise.main(["--seeds", "2", "--out", str(tmp_path / "report")]) == 0
    figure = tmp_path / "report" / "figures" / "s_hat_vs_noise.png"
    assert seeds == [2] and figure.read_bytes()[:4] == b"\x89PNG"
    assert [p.name for p in tmp_path.rglob("*")] == ["report", "figures", "s_hat_vs_noise.png"]
    assert capsys.readouterr().out.splitlines()[-1] == f"figure: {figure}"
