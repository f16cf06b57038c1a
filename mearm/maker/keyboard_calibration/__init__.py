"""``mearm calibrate-servos``: each servo's pulse calibration, jogged to two references.

The command is :mod:`mearm.maker.calibrate_servos`; its rooms, one way down:

- :mod:`.references`: the actuators, their two references, and where the other joints
  go before a joint's references.
- :mod:`.pulse_session`: the servo bus driven in pulses, the calibration being measured.
- :mod:`.calibrator`: the keys and the screen, one actuator after another, and the run
  that writes the file.
- :mod:`.simulated`: the same procedure with the MuJoCo twin jogging and reading.
"""
