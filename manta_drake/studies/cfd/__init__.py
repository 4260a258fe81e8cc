"""The hull's damping from CFD by the paper's method (section 2.3): static OpenFOAM analyses of
the simplified robot model (``geometry``, ``case``, ``run``), whose forces Eq. (4) is fitted
to. ``manta-drake study cfd`` (``study``) runs them; ``docs/cfd.md`` is the report."""


def main(argv=None, prog=None) -> int:
    """``manta-drake study cfd``: see ``manta_drake.studies.cfd.study``."""
    from manta_drake.studies.cfd.study import main as study_main

    return study_main(argv, prog)
