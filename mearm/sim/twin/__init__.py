"""The physical twin: the arm, table, bins and objects in MuJoCo, with its camera.

- :mod:`~mearm.sim.twin.mjcf`: the model, built with ``MjSpec`` on the arm's chain
  (:mod:`mearm.kinematics.mjspec`) and compiled once, from its rooms:
  :mod:`~mearm.sim.twin.twin_geoms` (units, materials, contact classes),
  :mod:`~mearm.sim.twin.twin_servos` (what each servo turns, its gains and range),
  :mod:`~mearm.sim.twin.twin_scene` (table, bins, objects, belt, lights, camera) and
  :mod:`~mearm.sim.twin.twin_scene_check` (the scene's checks);
- :mod:`~mearm.sim.twin.twin_bus`: :class:`~mearm.sim.twin.twin_bus.TwinArm`, the servo
  bus whose servos are physics;
- :mod:`~mearm.sim.twin.twin_optics` and :mod:`~mearm.sim.twin.twin_camera`: where the
  camera stands and what it sees, through its lens;
- :mod:`~mearm.sim.twin.calibration_scenes`: the boards and marker sheets it photographs
  for calibration.

Opened as ``simulator: mujoco`` (:mod:`mearm.backends`); it shares nothing with the
kinematic simulator but the arm's description.
"""
