"""s_hat against the depth camera's range noise: the wall detector's graceful degradation.

The robot stands on the pool floor facing the end wall at several distances; the camera
frame is rendered once per distance (VTK, as in the simulation), then for each noise level
and seed the station's noise (``noisy_depth``, 1 % pixel dropout), the controller's median
filter, ``DepthImageToPointCloud`` and the detector run on it. Prints the mean and the
range of s_hat per noise level and distance, and writes the figure
``DIR/figures/s_hat_vs_noise.png`` into ``--out DIR`` (default: the checkout's docs/; the
figure there was made with ``--seeds 6``).

Usage: manta-drake study wall-noise [--seeds 8] [--out docs]
"""

import pathlib

import numpy as np
from pydrake.perception import BaseField, DepthImageToPointCloud
from pydrake.systems.sensors import ImageDepth32F, PixelType

from manta_drake.config_io import check_integer
from manta_drake.control.vision import detect, median_filter_depth
from manta_drake.model.camera import camera_info
from manta_drake.scenario import load_scenario
from manta_drake.simulate import make_simulator
from manta_drake.station.depth_image_noise import noisy_depth
from manta_drake.studies.options import StudyParser, check_figure_file
from manta_drake.wiring.diagram import build_diagram

NOISE_MM = (0, 2.5, 5, 7.5, 10, 12.5, 15, 17.5, 20, 22.5, 25, 27.5, 30)
DISTANCES = (0.4, 0.5, 0.6, 0.7, 0.75, 1.0)


def wall_frame(distance: float):
    """(scenario, noiseless depth image, camera pose) with the camera ``distance`` m from
    the end wall, standing on the floor in the trot stance."""
    s = load_scenario("three_behaviors")
    s.visualization.meshcat = False
    s.initial_pose.xyz = [7.5 - 0.19 - distance, 0.0, -0.25]
    s.initial_stance, s.controller.mode, s.controller.gait = "trot", "hold", "trot"
    s.balloon.initial_fill, s.balloon.schedule = 0.0, []
    s.camera.depth_noise_std, s.camera.pixel_dropout = 0.0, 0.0
    diagram, h = build_diagram(s.validate())
    simulator = make_simulator(diagram, s)
    simulator.AdvanceTo(0.01)
    camera = h.systems["camera"]
    context = camera.GetMyContextFromRoot(simulator.get_context())
    image = camera.depth_image_32F_output_port().Eval(context)
    return s, image, camera.body_pose_in_world_output_port().Eval(context)


def s_hat_samples(s, image, X_WC, noise_std: float, seeds) -> np.ndarray:
    """s_hat of the frame under ``noise_std`` for each seed, through the real pipeline."""
    cam = s.camera
    to_cloud = DepthImageToPointCloud(
        camera_info(cam.width, cam.height, cam.fov_y_deg), PixelType.kDepth32F, 1.0, BaseField.kXYZs
    )
    context = to_cloud.CreateDefaultContext()
    to_cloud.camera_pose_input_port().FixValue(context, X_WC)
    out = []
    for seed in seeds:
        rng = np.random.default_rng(seed)
        n = image.data.size
        noisy = noisy_depth(
            image.data, noise_std, 0.01, rng.standard_normal(n), rng.uniform(size=n)
        )
        filtered = ImageDepth32F(image.width(), image.height())
        filtered.mutable_data[:] = median_filter_depth(
            noisy, s.wall_detector.depth_median_filter_px
        )
        to_cloud.depth_image_input_port().FixValue(context, filtered)
        xyz = to_cloud.point_cloud_output_port().Eval(context).xyzs()
        det = detect(xyz, s.wall_detector, X_WC.translation(), 0.0, X_WC.rotation().matrix()[:, 2])
        out.append(det.s_hat)
    return np.array(out)


# Each seed is one noisy frame per noise level and distance (78 frames of about 7 ms each
# through the filter and the detector): 1000 seeds take some ten minutes.
MAX_SEEDS = 1000


FIGURE = "s_hat_vs_noise.png"


def measure(seeds: int) -> dict:
    """{distance: [s_hat of every seed, per noise level of NOISE_MM]}."""
    table = {}
    for d in DISTANCES:
        s, image, X = wall_frame(d)
        table[d] = [s_hat_samples(s, image, X, mm * 1e-3, range(seeds)) for mm in NOISE_MM]
    return table


def print_table(table: dict) -> None:
    """The mean and the range of s_hat per noise level (rows) and distance (columns)."""
    print(f"{'noise mm':>9} " + " ".join(f"{'d=' + str(d) + ' m':>16}" for d in DISTANCES))
    for i, mm in enumerate(NOISE_MM):
        print(
            f"{mm:9.1f} "
            + " ".join(
                f"{table[d][i].mean():7.2f} [{table[d][i].min():.2f},{table[d][i].max():.2f}]"
                for d in DISTANCES
            )
        )


def plot(table: dict, seeds: int, path: pathlib.Path) -> None:
    """s_hat's mean over the seeds against the noise, one line per distance, with its range."""
    # Imported here, with the file-only backend: importing the study (``--help``) needs no
    # plotting, and a figure file needs no display.
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    for d, samples in table.items():
        ax.plot(NOISE_MM, [v.mean() for v in samples], marker="o", label=f"wall {d} m ahead")
        ax.fill_between(
            NOISE_MM, [v.min() for v in samples], [v.max() for v in samples], alpha=0.12
        )
    ax.set_xlabel("depth range noise (std) [mm]")
    ax.set_ylabel("s_hat (mean over seeds; band: min-max)")
    ax.set_ylim(-0.05, 1.05)
    ax.grid(alpha=0.3)
    ax.legend()
    ax.set_title(f"Wall detection under range noise (1 % dropout, {seeds} seeds)")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None, prog=None) -> int:
    """The command line (``manta-drake study wall-noise``); returns the exit status."""
    from manta_drake.studies.report import output_folder

    parser = StudyParser(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument(
        "--seeds",
        type=int,
        default=8,
        help=f"noise seeds per noise level and distance (1 to {MAX_SEEDS})",
    )
    parser.add_argument(
        "--out",
        type=pathlib.Path,
        metavar="DIR",
        help=f"where the figure goes: DIR/figures/{FIGURE} (default the checkout's docs/)",
    )
    args = parser.parse_args(argv)
    check_integer("--seeds", args.seeds, 1, MAX_SEEDS)  # before any frame is rendered
    path = output_folder(args.out, prog or "manta-drake study wall-noise") / "figures" / FIGURE
    check_figure_file("--out", path)
    table = measure(args.seeds)
    print_table(table)
    plot(table, args.seeds, path)
    print(f"figure: {path}")
    return 0
