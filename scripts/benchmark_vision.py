#!/usr/bin/env python3
"""Prints the wall detector's time per frame at several camera resolutions.

For each resolution the robot stands with its camera 0.6 m from the end wall of the pool; the script
renders depth images (VTK), converts them to point clouds, and times the detector
(WallDetector's pipeline: NaN removal, voxel downsampling, normals, normal-angle DBSCAN,
PCA labels, s_hat), the rendering and the conversion separately, over --frames frames
with the depth noise of the default scenario.

Usage: python scripts/benchmark_vision.py [--frames 20] [--resolutions 160x120 320x240]
"""

import argparse
import sys
import time

import numpy as np

from manta_drake.control.vision import detect
from manta_drake.diagram import build_diagram, initialize_context
from manta_drake.model.plant import body_pose, set_initial_state
from manta_drake.scenario import (
    ControllerConfig,
    InitialPose,
    Scenario,
    VisualizationConfig,
)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=20)
    parser.add_argument("--resolutions", nargs="+", default=["160x120", "320x240", "640x480"])
    args = parser.parse_args()
    print(f"{'resolution':>10s} {'points':>7s} {'render':>9s} {'to cloud':>9s} "
          f"{'detector':>9s} {'s_hat':>6s}")
    for res in args.resolutions:
        width, height = (int(x) for x in res.split("x"))
        s = Scenario(name="bench", initial_stance="trot",
                     controller=ControllerConfig(mode="hold", gait="trot"),
                     initial_pose=InitialPose(xyz=[7.5 - 0.6 - 0.19, 0.0, -0.25]),
                     visualization=VisualizationConfig(meshcat=False))
        s.camera.enabled, s.camera.width, s.camera.height = True, width, height
        diagram, h = build_diagram(s.validate())
        context = diagram.CreateDefaultContext()
        set_initial_state(h.plant_handles, h.plant.GetMyMutableContextFromRoot(context),
                          body_pose(s.initial_pose.xyz, [0, 0, 0]), np.zeros(16))
        initialize_context(s, h, context)
        cam, noise = h.systems["camera"], h.systems["depth_noise"]
        to_cloud, detector = h.systems["depth_to_cloud"], h.systems["wall_detector"]
        t_render, t_cloud, t_detect = [], [], []
        for k in range(args.frames + 1):
            context.SetTime(0.2 * k)  # a new frame: new noise, caches invalidated
            start = time.perf_counter()
            cam.depth_image_32F_output_port().Eval(cam.GetMyContextFromRoot(context))
            t1 = time.perf_counter()
            cloud = to_cloud.point_cloud_output_port().Eval(to_cloud.GetMyContextFromRoot(context))
            t2 = time.perf_counter()
            X_WC = cam.body_pose_in_world_output_port().Eval(cam.GetMyContextFromRoot(context))
            det = detect(cloud.xyzs(), detector.params, X_WC.translation(), 0.0,
                         X_WC.rotation().matrix()[:, 2])
            t3 = time.perf_counter()
            if k > 0:  # the first frame pays for set-up
                t_render.append(t1 - start)
                t_cloud.append(t2 - t1)
                t_detect.append(t3 - t2)
        del noise
        print(f"{res:>10s} {det.num_points:7d} {np.median(t_render) * 1e3:7.1f}ms "
              f"{np.median(t_cloud) * 1e3:7.1f}ms {np.median(t_detect) * 1e3:7.1f}ms "
              f"{det.s_hat:6.2f}")
    print("(medians per frame; points = after voxel downsampling)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
