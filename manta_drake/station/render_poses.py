"""The camera's own scene: ``RenderPoses`` and ``add_camera_scene``.

The head camera renders from a SceneGraph of its own, posed from the plant's body poses
only when a frame is rendered (see ``add_camera_scene`` for why).
"""

from pydrake.common.value import AbstractValue
from pydrake.geometry import (
    FramePoseVector,
    GeometryFrame,
    GeometryInstance,
    MakeRenderEngineVtk,
    PerceptionProperties,
    RenderEngineVtkParams,
    Role,
    SceneGraph,
)
from pydrake.multibody.tree import BodyIndex
from pydrake.systems.framework import LeafSystem

from manta_drake.model.plant import PlantHandles


class RenderPoses(LeafSystem):
    """The poses of the camera scene's frames (one per plant body with perception
    geometry), read from the plant's body poses when the camera renders.

    .. pydrake_system::

        name: RenderPoses
        input_ports:
        - body_poses
        output_ports:
        - geometry_pose

    * ``body_poses``: the plant's output of that name.
    * ``geometry_pose``: a FramePoseVector for the camera SceneGraph's source.

    Nothing but the camera asks for ``geometry_pose``, so it is evaluated only when a
    frame is rendered (at the camera's rate), not at every plant step.
    """

    def __init__(self, plant, frames):
        """``frames``: (FrameId in the camera scene, BodyIndex in the plant) pairs."""
        super().__init__()
        self._frames = [(frame_id, int(index)) for frame_id, index in frames]
        self._poses = self.DeclareAbstractInputPort(
            "body_poses", plant.get_body_poses_output_port().Allocate()
        )
        # It depends on the body poses only (not on time), so a plant step that does not
        # move the robot leaves the rendered frame valid in the cache.
        self.DeclareAbstractOutputPort(
            "geometry_pose",
            lambda: AbstractValue.Make(FramePoseVector()),
            self._calc,
            prerequisites_of_calc={self.input_port_ticket(self._poses.get_index())},
        )

    def _calc(self, context, output):
        poses = self._poses.Eval(context)
        vector = output.get_mutable_value()
        for frame_id, index in self._frames:
            vector.set_value(frame_id, poses[index])


def add_camera_scene(builder, handles: PlantHandles):
    """A SceneGraph of its own for the camera, with a VTK renderer and a copy of every
    geometry of the plant that has the perception role (the robot and the pool), posed
    from the plant's body poses through ``RenderPoses``.

    Why not render from the plant's own SceneGraph: a SceneGraph moves every render
    engine's geometry whenever its poses are updated, and the plant's are updated at every
    step (contact queries), so a renderer there costs a VTK pose update per plant step
    (~80 us) for a camera that takes 5 frames a second. Here the poses are computed and
    pushed to VTK only when a frame is rendered. The images are the same: same geometry,
    same properties, same poses at the frame's time.

    Returns:
        (camera SceneGraph, RenderPoses system, {plant body index (int): FrameId in the
        camera scene}); the robot's main body always has a frame (the camera's mount).
    """
    plant, plant_scene = handles.plant, handles.scene_graph
    inspector = plant_scene.model_inspector()
    scene = builder.AddNamedSystem("camera_scene_graph", SceneGraph())
    scene.AddRenderer("vtk", MakeRenderEngineVtk(RenderEngineVtkParams()))
    source = scene.RegisterSource("camera_scene")
    world, mount = int(plant.world_body().index()), int(handles.body.index())
    frames = {}
    for index in range(plant.num_bodies()):
        body = plant.get_body(BodyIndex(index))
        geometries = inspector.GetGeometries(
            plant.GetBodyFrameIdOrThrow(body.index()), Role.kPerception
        )
        if not geometries and index != mount:
            continue
        if index == world:
            frame = scene.world_frame_id()
        else:
            frame = scene.RegisterFrame(source, GeometryFrame(body.scoped_name().get_full()))
            frames[index] = frame
        for geometry in geometries:
            instance = GeometryInstance(
                inspector.GetPoseInFrame(geometry),
                inspector.GetShape(geometry),
                inspector.GetName(geometry),
            )
            instance.set_perception_properties(
                PerceptionProperties(inspector.GetPerceptionProperties(geometry))
            )
            if frame == scene.world_frame_id():
                scene.RegisterAnchoredGeometry(source, instance)
            else:
                scene.RegisterGeometry(source, frame, instance)
    poses = builder.AddNamedSystem(
        "camera_render_poses",
        RenderPoses(plant, [(frame, index) for index, frame in frames.items()]),
    )
    builder.Connect(plant.get_body_poses_output_port(), poses.GetInputPort("body_poses"))
    builder.Connect(poses.GetOutputPort("geometry_pose"), scene.get_source_pose_port(source))
    return scene, poses, frames
