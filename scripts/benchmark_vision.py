#!/usr/bin/env python3
"""Prints the camera pipeline's time per frame at several camera resolutions.

For each resolution the robot stands in the trot stance with its camera 0.6 m from the end
wall of the pool (the station's camera: VTK in the camera's own SceneGraph, see
``manta_drake.station.render_poses.add_camera_scene``; ``--camera-in-plant-scene`` renders
in the plant's SceneGraph instead, ``build_diagram(..., camera_own_scene=False)``). Over
--frames frames it times, per frame: rendering the depth image, adding the depth noise, the
controller's depth-image filter (where it has one), converting to a point cloud, and the
wall detector's pipeline (NaN removal, voxel downsampling, normals, normal-angle DBSCAN,
PCA labels, s_hat). The first frame (renderer set-up) is reported apart.

Usage: python scripts/benchmark_vision.py [--frames 20] [--resolutions 160x120 320x240]
       [--camera-in-plant-scene]
"""

import argparse
import sys
import time

import numpy as np

from manta_drake.control.vision import detect
from manta_drake.scenario import (
    ControllerConfig,
    InitialPose,
    Scenario,
    VisualizationConfig,
)
from manta_drake.simulate import make_simulator
from manta_drake.wiring.diagram import build_diagram


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=20)
    parser.add_argument("--resolutions", nargs="+", default=["160x120", "320x240", "640x480"])
    parser.add_argument(
        "--camera-in-plant-scene",
        action="store_true",
        help="render in the plant's SceneGraph instead of the camera's own",
    )
    args = parser.parse_args()
    print(
        f"{'resolution':>10s} {'points':>7s} {'1st frame':>9s} {'render':>9s} {'noise':>9s} "
        f"{'filter':>9s} {'to cloud':>9s} {'detector':>9s} {'s_hat':>6s}"
    )
    for res in args.resolutions:
        width, height = (int(x) for x in res.split("x"))
        s = Scenario(
            name="bench",
            initial_stance="trot",
            controller=ControllerConfig(mode="hold", gait="trot"),
            initial_pose=InitialPose(xyz=[7.5 - 0.6 - 0.19, 0.0, -0.235]),
            visualization=VisualizationConfig(meshcat=False),
        )
        s.camera.enabled, s.camera.width, s.camera.height = True, width, height
        diagram, h = build_diagram(s.validate(), camera_own_scene=not args.camera_in_plant_scene)
        simulator = make_simulator(diagram, s)  # the scenario's start, noise seeded
        context = simulator.get_mutable_context()
        plant, plant_context = h.plant, h.plant.GetMyMutableContextFromRoot(context)
        q0 = plant.GetPositions(plant_context)
        cam, noise = h.systems["camera"], h.systems["depth_noise"]
        to_cloud, detector = h.systems["depth_to_cloud"], h.systems["wall_detector"]
        # The controller's depth-image filter, where it has one (between noise and cloud).
        depth_filter = (
            h.controller.GetSubsystemByName("depth_filter")
            if h.controller.HasSubsystemNamed("depth_filter")
            else None
        )
        cam_context = cam.GetMyContextFromRoot(context)
        noise_context = noise.GetMyContextFromRoot(context)
        cloud_context = to_cloud.GetMyContextFromRoot(context)
        t_render, t_noise, t_filter, t_cloud, t_detect = [], [], [], [], []
        first = 0.0
        for k in range(args.frames + 1):
            # A new pose each frame (1 mm sideways) so the frame is really rendered again.
            q = q0.copy()
            q[5] += 1e-3 * k
            plant.SetPositions(plant_context, q)
            start = time.perf_counter()
            cam.depth_image_32F_output_port().Eval(cam_context)
            t1 = time.perf_counter()
            noise.GetOutputPort("noisy_depth_image").Eval(noise_context)
            t2 = time.perf_counter()
            if depth_filter is not None:
                depth_filter.get_output_port().Eval(depth_filter.GetMyContextFromRoot(context))
            t2f = time.perf_counter()
            cloud = to_cloud.point_cloud_output_port().Eval(cloud_context)
            t3 = time.perf_counter()
            X_WC = cam.body_pose_in_world_output_port().Eval(cam_context)
            det = detect(
                cloud.xyzs(),
                detector.params,
                X_WC.translation(),
                0.0,
                X_WC.rotation().matrix()[:, 2],
            )
            t4 = time.perf_counter()
            if k == 0:  # the first frame pays for the renderer's set-up
                first = t1 - start
                continue
            t_render.append(t1 - start)
            t_noise.append(t2 - t1)
            t_filter.append(t2f - t2)
            t_cloud.append(t3 - t2f)
            t_detect.append(t4 - t3)
        print(
            f"{res:>10s} {det.num_points:7d} {first * 1e3:7.1f}ms "
            f"{np.median(t_render) * 1e3:7.1f}ms {np.median(t_noise) * 1e3:7.1f}ms "
            f"{np.median(t_filter) * 1e3:7.1f}ms "
            f"{np.median(t_cloud) * 1e3:7.1f}ms {np.median(t_detect) * 1e3:7.1f}ms "
            f"{det.s_hat:6.2f}"
        )
    print("(medians per frame; points = after voxel downsampling)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
