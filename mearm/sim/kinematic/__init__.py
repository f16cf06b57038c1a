"""The kinematic simulator: a table of objects, its picture, and an arm that moves at once.

- :mod:`~mearm.sim.kinematic.world`: :class:`World`, the objects and the bins;
- :mod:`~mearm.sim.kinematic.renderer` and :mod:`~mearm.sim.kinematic.table_camera`: the
  camera's picture of the table, drawn afresh at every read (:class:`SimCamera`);
- :mod:`~mearm.sim.kinematic.servo_bus`: :class:`SimArm`, the servo bus over the world
  (the servos' quantization and noise, grips and releases, the collision model's faults);
- :mod:`~mearm.sim.kinematic.joint_stops`: where a joint sent past its limits stops;
- :mod:`~mearm.sim.kinematic.vision_scenes`: rendered scenes for the detector's bench.

The virtual Uno (:mod:`mearm.sim.virtual_uno`) moves this arm by its firmware's pulses.
"""
