"""kin: solvers (dyads, triads, generic groups), kinematics of whole mechanisms,
kinetostatics, the engine module, screw theory of spatial platforms, plots."""
