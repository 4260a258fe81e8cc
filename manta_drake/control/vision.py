"""Wall detection from the head camera's point cloud (section 3.2, Eq. 10).

Pipeline (each step a plain function the tests call directly):

1. ``finite_points``: drop NaN/inf points (missing depth, pixel dropout, out of range).
2. ``downsample_with_normals``: voxel downsampling and normal estimation (open3d).
3. ``normal_dbscan``: DBSCAN whose neighbour relation is Eq. (10):
   ``|p_i - p_j| <= N_Eps AND angle(n_i, n_j) <= theta_threshold`` (normals are
   unoriented, so the angle is between the lines). Neighbour pairs come from scipy's
   KD-tree, clusters from ``scipy.sparse.csgraph.connected_components`` over the
   core points; border points join a neighbouring core point's cluster. Where a wall
   meets the floor the normal test cuts the corner that a plain distance DBSCAN
   bridges. Because estimated normals turn gradually across a corner, a point may be
   a core point only where its neighbourhood is planar (surface variation
   lambda_0 / sum(lambda) <= ``max_surface_variation``, the curvature guard of
   region-growing segmentation, Rabbani et al. 2006); otherwise a chain of
   neighbours could still creep round the corner in steps below theta_threshold.
4. ``describe_cluster``: PCA of each cluster; the smallest principal axis is the
   plane normal. Planar clusters with a vertical normal are ``floor`` (below the
   camera) or ``ceiling`` (above it: the water surface), planar clusters with a
   horizontal normal are ``wall``, anything else (or small) is ``object``.
   Curved points left over (not planar, so never core points) are clustered by
   distance alone and labelled ``object``.
5. ``wall_score``: s_hat = 1 / (1 + exp(-k (c - c_mid))), c_mid = (c_min + c_max) / 2,
   of the size c (points after downsampling) of the largest wall cluster *ahead*
   (its normal within ``frontal_angle_deg`` of the camera's horizontal viewing
   direction; in the 2 m wide pool the side walls are always in view and must not
   trigger the turn); 0 when no such wall is seen. The default k = 10 / (c_max - c_min) puts
   s_hat at 0.7 % at c_min and 99.3 % at c_max.
"""

import dataclasses as dc

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform
from pydrake.perception import PointCloud
from pydrake.systems.framework import LeafSystem
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from manta_drake.config_io import ScenarioError, field_name

LABELS = ("floor", "ceiling", "wall", "object")
LABEL_COLORS = {
    "floor": (0.55, 0.35, 0.2),
    "ceiling": (0.2, 0.6, 1.0),
    "wall": (0.9, 0.15, 0.15),
    "object": (0.95, 0.8, 0.1),
}


@dc.dataclass
class WallDetectorParams:
    """Parameters of the detector (lengths in m). Defaults suit the pool and a
    160 x 120 depth camera; see the module docstring for what each does."""

    voxel_size: float = 0.04
    normal_radius: float = 0.10  # neighbourhood for normal estimation
    normal_max_neighbors: int = 16
    eps: float = 0.07  # N_Eps of Eq. (10)
    min_points: int = 5  # DBSCAN core-point threshold (neighbours incl. itself)
    max_surface_variation: float = 0.04  # core points only where locally planar
    theta_threshold_deg: float = 25.0  # theta_threshold of Eq. (10)
    min_cluster_size: int = 12  # smaller clusters are labelled "object"
    planarity: float = 0.05  # lambda_min / lambda_mid below this is a plane
    orientation_tolerance_deg: float = 25.0  # normal within this of vertical/horizontal
    frontal_angle_deg: float = 45.0  # walls ahead: normal within this of the view direction
    # Eq. (10)'s cluster-size bounds, in 4 cm voxels: 11 is ~0.02 m^2 of wall, 68 ~0.11 m^2.
    c_min: float = 11.0
    c_max: float = 68.0
    k: float = 0.0  # sigmoid slope; 0 means 10 / (c_max - c_min)

    # Median filter on the depth image before the point cloud (pixels; 0 or 1: off), as a
    # depth camera's spatial filter: at >= 10 mm of range noise the voxelised wall becomes
    # a double sheet whose surface variation fails the curvature guard and the wall was lost.
    depth_median_filter_px: int = 5

    # (name, low, high, integer, low open): the allowed range of every field.
    RANGES = (
        ("voxel_size", 0.005, 0.5, False, False),
        ("normal_radius", 0.01, 1.0, False, False),
        ("normal_max_neighbors", 3, 200, True, False),  # 0 crashes open3d
        ("eps", 0.005, 1.0, False, False),
        ("min_points", 1, 1000, True, False),
        ("max_surface_variation", 0.0, 1.0 / 3.0, False, True),
        ("theta_threshold_deg", 0.0, 90.0, False, True),
        ("min_cluster_size", 1, 100000, True, False),
        ("planarity", 0.0, 1.0, False, True),
        ("orientation_tolerance_deg", 0.0, 45.0, False, True),
        ("frontal_angle_deg", 0.0, 90.0, False, True),
        ("c_min", 0.0, 1e6, False, False),
        ("c_max", 0.0, 1e6, False, True),
        ("k", 0.0, 1e3, False, False),
        ("depth_median_filter_px", 0, 15, True, False),
    )

    def validate(self, where: str = "") -> "WallDetectorParams":
        """Checks every field's type and range; ScenarioError names the field
        (``<where>.<field>``), the value and the allowed range."""
        for name, lo, hi, integer, open_low in self.RANGES:
            value = getattr(self, name)
            kind = "an integer" if integer else "a number"
            if isinstance(value, bool) or not isinstance(value, int if integer else (int, float)):
                raise ScenarioError(f"{field_name(where, name)}: {value!r} is not {kind}")
            bracket = "(" if open_low else "["
            if not (
                np.isfinite(value) and (value > lo if open_low else value >= lo) and value <= hi
            ):
                raise ScenarioError(
                    f"{field_name(where, name)}: {value!r} is outside the allowed range "
                    f"{bracket}{lo:g}, {hi:g}]"
                )
        if not self.c_min < self.c_max:
            raise ScenarioError(
                f"{field_name(where, 'c_min')}: {self.c_min!r} must be below c_max = {self.c_max!r}"
            )
        if self.depth_median_filter_px > 1 and self.depth_median_filter_px % 2 == 0:
            raise ScenarioError(
                f"{field_name(where, 'depth_median_filter_px')}: "
                f"{self.depth_median_filter_px!r} must be odd (0 or 1: no filter)"
            )
        return self


@dc.dataclass
class Cluster:
    """One labelled cluster."""

    points: np.ndarray  # (n, 3), world frame
    label: str
    size: int
    centroid: np.ndarray
    normal: np.ndarray  # unit, smallest principal axis


@dc.dataclass
class Detection:
    """What the detector saw in one frame."""

    time: float = 0.0
    s_hat: float = 0.0
    wall_size: int = 0
    clusters: list = dc.field(default_factory=list)
    num_points: int = 0


# --- pure functions ---------------------------------------------------------------------------


def finite_points(xyz) -> np.ndarray:
    """(N, 3) points with every coordinate finite. Accepts (N, 3) or Drake's (3, N)."""
    xyz = np.asarray(xyz, dtype=float)
    if xyz.ndim != 2 or 3 not in xyz.shape:
        raise ValueError(f"expected an (N, 3) or (3, N) array of points, got shape {xyz.shape}")
    if xyz.shape[1] != 3:
        xyz = xyz.T
    return xyz[np.all(np.isfinite(xyz), axis=1)]


def downsample_with_normals(xyz: np.ndarray, p: WallDetectorParams) -> tuple:
    """Voxel-downsampled points, unit normals and surface variation (open3d).

    Returns:
        (points (N, 3), normals (N, 3), variation (N,)): variation is
        lambda_0 / (lambda_0 + lambda_1 + lambda_2) of each point's neighbourhood
        covariance (0 on a plane, 1/3 for isotropic scatter).
    """
    import open3d as o3d

    if len(xyz) == 0:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0)
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(xyz))
    cloud = cloud.voxel_down_sample(p.voxel_size)
    n = len(cloud.points)
    if n < 3:
        return np.asarray(cloud.points), np.tile([0.0, 0.0, 1.0], (n, 1)), np.ones(n) / 3
    search = o3d.geometry.KDTreeSearchParamHybrid(
        radius=p.normal_radius, max_nn=p.normal_max_neighbors
    )
    cloud.estimate_covariances(search)
    eigval, eigvec = np.linalg.eigh(np.asarray(cloud.covariances))
    variation = eigval[:, 0] / np.maximum(eigval.sum(axis=1), 1e-15)
    return np.asarray(cloud.points), eigvec[:, :, 0], variation


def normal_dbscan(
    points: np.ndarray,
    normals: np.ndarray | None,
    eps: float,
    min_points: int,
    theta_threshold_deg: float | None,
    variation: np.ndarray | None = None,
    max_variation: float | None = None,
) -> np.ndarray:
    """DBSCAN labels (-1: noise) with Eq. (10)'s neighbour relation.

    Args:
        points: (N, 3).
        normals: (N, 3) unit normals, or None for a plain distance DBSCAN.
        eps: neighbour distance N_Eps.
        min_points: a core point has at least this many neighbours, itself included.
        theta_threshold_deg: largest angle between neighbours' normals (None: no test).
        variation, max_variation: if given, only points with variation <= max_variation
            may be core points (the curvature guard).
    """
    n = len(points)
    if n == 0:
        return np.zeros(0, dtype=int)
    pairs = cKDTree(points).query_pairs(eps, output_type="ndarray")
    if normals is not None and theta_threshold_deg is not None and len(pairs):
        cos_angle = np.abs(np.einsum("ij,ij->i", normals[pairs[:, 0]], normals[pairs[:, 1]]))
        pairs = pairs[cos_angle >= np.cos(np.radians(theta_threshold_deg))]
    counts = 1 + np.bincount(pairs.ravel(), minlength=n)
    core = counts >= min_points
    if variation is not None and max_variation is not None:
        core &= variation <= max_variation
    labels = np.full(n, -1, dtype=int)
    if not core.any():
        return labels
    both = core[pairs[:, 0]] & core[pairs[:, 1]]
    cp = pairs[both]
    core_idx = np.flatnonzero(core)
    remap = np.full(n, -1)
    remap[core_idx] = np.arange(len(core_idx))
    graph = coo_matrix(
        (np.ones(len(cp)), (remap[cp[:, 0]], remap[cp[:, 1]])), shape=(len(core_idx), len(core_idx))
    )
    _, comp = connected_components(graph, directed=False)
    labels[core_idx] = comp
    # Border points: non-core points with a core neighbour take that neighbour's cluster.
    for a, b in ((0, 1), (1, 0)):
        border = core[pairs[:, a]] & ~core[pairs[:, b]]
        labels[pairs[border, b]] = labels[pairs[border, a]]
    return labels


def describe_cluster(points: np.ndarray, viewpoint, p: WallDetectorParams) -> Cluster:
    """PCA of a cluster and its label (floor, ceiling, wall or object)."""
    centroid = points.mean(axis=0)
    if len(points) >= 3:
        eigval, eigvec = np.linalg.eigh(np.cov((points - centroid).T))
        normal = eigvec[:, 0]
        planar = eigval[0] <= p.planarity * max(eigval[1], 1e-12)
    else:
        normal, planar = np.array([0.0, 0.0, 1.0]), False
    tol = np.radians(p.orientation_tolerance_deg)
    nz = abs(normal[2])
    if len(points) < p.min_cluster_size or not planar:
        label = "object"
    elif nz >= np.cos(tol):
        label = "floor" if centroid[2] < viewpoint[2] else "ceiling"
    elif nz <= np.sin(tol):
        label = "wall"
    else:
        label = "object"
    return Cluster(points, label, len(points), centroid, normal)


def median_filter_depth(depth, size: int) -> np.ndarray:
    """A ``size`` x ``size`` median filter of a depth image (H, W[, 1]), float32, as a depth
    camera's spatial filter. Missing pixels (NaN dropouts, inf out of range) count as
    "no return" (+inf), so a lone dropout is filled from its neighbours and a region with
    mostly no return stays without. Edges repeat the border pixels. ``size`` <= 1 returns a
    copy. (A partition over a sliding-window view: equal to scipy.ndimage.median_filter
    with mode "nearest" for odd sizes, and 2.5x faster at 160 x 120.)"""
    from numpy.lib.stride_tricks import sliding_window_view

    d = np.array(depth, dtype=np.float32, copy=True)
    if size <= 1:
        return d
    shape = d.shape
    d = d.reshape(shape[0], shape[1])
    d[~np.isfinite(d)] = np.inf
    r = size // 2
    windows = sliding_window_view(np.pad(d, r, mode="edge"), (size, size))
    windows = windows.reshape(shape[0], shape[1], size * size)
    k = (size * size) // 2
    return np.partition(windows, k, axis=-1)[..., k].reshape(shape)


def wall_score(c: float, p: WallDetectorParams) -> float:
    """Eq. (10): s_hat = sigmoid(k (c - c_mid)); 0 when there is no wall (c = 0)."""
    if c <= 0:
        return 0.0
    k = p.k if p.k > 0 else 10.0 / (p.c_max - p.c_min)
    c_mid = 0.5 * (p.c_min + p.c_max)
    return float(1.0 / (1.0 + np.exp(-k * (c - c_mid))))


def is_ahead(cluster: Cluster, view_direction, p: WallDetectorParams) -> bool:
    """A wall faces the camera: its normal is within frontal_angle_deg of the horizontal
    viewing direction (None: every wall counts)."""
    if view_direction is None:
        return True
    d = np.array([view_direction[0], view_direction[1], 0.0])
    n = np.array([cluster.normal[0], cluster.normal[1], 0.0])
    norms = np.linalg.norm(d) * np.linalg.norm(n)
    return bool(norms > 0 and abs(d @ n) / norms >= np.cos(np.radians(p.frontal_angle_deg)))


def detect(
    xyz, p: WallDetectorParams, viewpoint=(0.0, 0.0, 0.0), time: float = 0.0, view_direction=None
) -> Detection:
    """The whole pipeline on one cloud. Never raises on empty or all-NaN input.

    Args:
        xyz: (N, 3) or (3, N) points in the world.
        viewpoint: camera position (its height tells floor from ceiling).
        view_direction: camera optical axis in the world, or None to count every wall.
    """
    pts = finite_points(xyz) if np.size(xyz) else np.zeros((0, 3))
    down, normals, variation = downsample_with_normals(pts, p)
    labels = normal_dbscan(
        down,
        normals,
        p.eps,
        p.min_points,
        p.theta_threshold_deg,
        variation,
        p.max_surface_variation,
    )
    viewpoint = np.asarray(viewpoint, dtype=float)
    clusters = [
        describe_cluster(down[labels == i], viewpoint, p)
        for i in range(labels.max() + 1 if len(labels) else 0)
    ]
    # Leftovers (never core points under the curvature guard) are clustered by distance
    # alone and labelled by their PCA like the others: a corner's leftovers are an L, not a
    # plane, and stay "object"; a noisy wall whose points all failed the guard is still a
    # plane (and was lost to "object" before at >= 10 mm of noise).
    curved = np.flatnonzero((labels < 0) & (variation > p.max_surface_variation))
    rest = normal_dbscan(down[curved], None, p.eps, p.min_points, None)
    for i in range(rest.max() + 1 if len(rest) else 0):
        clusters.append(describe_cluster(down[curved[rest == i]], viewpoint, p))
    clusters.sort(key=lambda c: -c.size)
    walls = [c.size for c in clusters if c.label == "wall" and is_ahead(c, view_direction, p)]
    c = max(walls) if walls else 0
    return Detection(time, wall_score(c, p), c, clusters, len(down))


# --- the system ------------------------------------------------------------------------------

# Per-frame counters, a discrete state (logged like any other signal).
STATUS_FIELDS = ("s_hat", "wall_size", "num_points", "frames", "failed_frames")


def is_expected_frame_failure(error: Exception) -> bool:
    """Failures a frame may have without the run being wrong: a degenerate covariance in
    the linear algebra, or an error reported by open3d (``[Open3D ERROR] ...``). Anything
    else is a bug and must fail the run."""
    if isinstance(error, np.linalg.LinAlgError):
        return True
    return isinstance(error, RuntimeError) and "open3d" in str(error).lower()


class WallDetector(LeafSystem):
    """Point-cloud wall detector (Eq. 10), run as a periodic update at the camera rate.

    .. pydrake_system::

        name: WallDetector
        input_ports:
        - point_cloud
        - camera_pose (optional)
        output_ports:
        - s_hat
        - clusters
        - best_clusters
        - detector_status

    * ``point_cloud``: a Drake PointCloud in the world frame (from DepthImageToPointCloud).
    * ``camera_pose`` (optional): the camera's RigidTransform in the world; its height
      tells floor from ceiling and its optical axis which walls are ahead.
      Unconnected, the viewpoint is the world origin and every wall counts.
    * ``s_hat`` (1): wall detection rate in [0, 1], held between frames.
    * ``clusters``: the last frame's ``Detection`` (labelled clusters), held.
    * ``best_clusters``: the ``Detection`` of the frame with the largest wall so far.
    * ``detector_status`` (5): ``STATUS_FIELDS`` = s_hat, wall size of the last frame,
      its number of points after downsampling, frames processed, frames failed.

    All of it is state in the Context (one discrete vector, two abstract values), so
    one diagram can be simulated from many contexts. A frame that fails in an expected
    way (``is_expected_frame_failure``) keeps the previous output and is counted in
    ``failed_frames``; any other exception propagates and fails the run with its
    reason. With ``meshcat``, a publish event at the camera rate draws the last frame's
    labelled clusters (drawing never changes the state).
    """

    def __init__(self, period: float, params: WallDetectorParams | None = None, meshcat=None):
        super().__init__()
        if not (np.isfinite(period) and period > 0):
            raise ValueError(f"WallDetector.period: {period} must be > 0")
        try:
            self.params = (params or WallDetectorParams()).validate()
        except ValueError as e:
            raise ValueError(f"WallDetector.params.{e}") from None
        self._meshcat = meshcat
        self._cloud = self.DeclareAbstractInputPort("point_cloud", AbstractValue.Make(PointCloud()))
        self._camera = self.DeclareAbstractInputPort(
            "camera_pose", AbstractValue.Make(RigidTransform())
        )
        self._status = self.DeclareDiscreteState(np.zeros(len(STATUS_FIELDS)))
        self._detection = self.DeclareAbstractState(AbstractValue.Make(Detection()))
        self._best = self.DeclareAbstractState(AbstractValue.Make(Detection()))
        self.DeclareVectorOutputPort(
            "s_hat",
            1,
            lambda c, o: o.SetAtIndex(0, c.get_discrete_state(self._status)[0]),
            prerequisites_of_calc={self.xd_ticket()},
        )
        self.DeclareStateOutputPort("clusters", self._detection)
        self.DeclareStateOutputPort("best_clusters", self._best)
        self.DeclareStateOutputPort("detector_status", self._status)
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, 0.0, self._update)
        if meshcat is not None:
            self.DeclarePeriodicPublishEvent(period, 0.0, self._publish)

    def _update(self, context, state):
        if self._camera.HasValue(context):
            X_WC = self._camera.Eval(context)
            viewpoint, view = X_WC.translation(), X_WC.rotation().matrix()[:, 2]
        else:
            viewpoint, view = np.zeros(3), None
        status = context.get_discrete_state(self._status).get_value().copy()
        status[3] += 1
        try:
            xyz = self._cloud.Eval(context).xyzs()
            detection = detect(xyz, self.params, viewpoint, context.get_time(), view)
        except Exception as e:
            if not is_expected_frame_failure(e):
                raise RuntimeError(
                    f"WallDetector: frame at t = {context.get_time():.3f} s "
                    f"failed: {type(e).__name__}: {e}"
                ) from e
            status[4] += 1  # hold the last output
            state.get_mutable_discrete_state(self._status).SetFromVector(status)
            return
        status[:3] = detection.s_hat, detection.wall_size, detection.num_points
        state.get_mutable_discrete_state(self._status).SetFromVector(status)
        state.get_mutable_abstract_state(self._detection).set_value(detection)
        best = context.get_abstract_state(self._best).get_value()
        if detection.wall_size > best.wall_size or best.num_points == 0:
            state.get_mutable_abstract_state(self._best).set_value(detection)

    def _publish(self, context):
        publish_clusters(self._meshcat, context.get_abstract_state(self._detection).get_value())


def publish_clusters(meshcat, detection: Detection, prefix: str = "/wall_detector") -> None:
    """Shows the labelled clusters in Meshcat, one colour per label."""
    from pydrake.geometry import Rgba

    for label in LABELS:
        pts = [c.points for c in detection.clusters if c.label == label]
        xyz = np.vstack(pts) if pts else np.zeros((0, 3))
        cloud = PointCloud(len(xyz))
        cloud.mutable_xyzs()[:] = xyz.T
        meshcat.SetObject(
            f"{prefix}/{label}", cloud, point_size=0.02, rgba=Rgba(*LABEL_COLORS[label], 1.0)
        )
