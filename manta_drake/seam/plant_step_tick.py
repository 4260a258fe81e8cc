"""``PlantStepTick``: a periodic publish event every plant step, so the controller alone
steps its CPG as the single diagram does."""

from pydrake.systems.framework import DiagramBuilder, LeafSystem


class PlantStepTick(LeafSystem):
    """A periodic publish event that does nothing, every plant step.

    Why: Drake's integrator stretches a step by up to 1 % to land on an update or
    publish event, but never steps past an ``AdvanceTo`` boundary. In the single
    diagram the plant's update at (k+1) h is the CPG's RK2 target, so a step from
    k h is stretched onto it even when (k+1) h - k h is a rounding error more than
    h; in the controller alone only the boundary would be there, and the integrator
    would take h and then a ~1e-16 s step. With this event in the controller's
    diagram its RK2 steps are the single diagram's, bit for bit.
    """

    def __init__(self, period: float):
        super().__init__()
        self.DeclarePeriodicPublishEvent(period, 0.0, lambda context: None)


def controller_with_tick(controller, period: float):
    """``controller`` and a ``PlantStepTick(period)`` in one Diagram with the
    controller's port names."""
    builder = DiagramBuilder()
    builder.AddSystem(controller)
    builder.AddNamedSystem("plant_step_tick", PlantStepTick(period))
    for i in range(controller.num_input_ports()):
        port = controller.get_input_port(i)
        builder.ExportInput(port, port.get_name())
    for i in range(controller.num_output_ports()):
        port = controller.get_output_port(i)
        builder.ExportOutput(port, port.get_name())
    diagram = builder.Build()
    diagram.set_name("controller_alone")
    return diagram
