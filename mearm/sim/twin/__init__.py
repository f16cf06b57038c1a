"""The physical twin: the arm, table, bins and objects in MuJoCo, with its camera.

- :mod:`~mearm.sim.twin.mjcf`: the model, built with ``MjSpec`` on the arm's chain
  (:mod:`mearm.kinematics.mjspec`) and compiled once;
- :mod:`~mearm.sim.twin.twin_bus`: :class:`~mearm.sim.twin.twin_bus.TwinArm`, the servo
  bus whose servos are physics;
- :mod:`~mearm.sim.twin.twin_optics` and :mod:`~mearm.sim.twin.twin_camera`: where the
  camera stands and what it sees, through its lens;
- :mod:`~mearm.sim.twin.calibration_scenes`: the boards and marker sheets it photographs
  for calibration.

Opened as ``simulator: mujoco`` (:mod:`mearm.backends`); it shares nothing with the
kinematic simulator but the arm's description.
"""
