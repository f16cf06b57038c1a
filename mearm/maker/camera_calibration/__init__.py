"""``mearm calibrate-servos --camera``: the joint servos fitted to where the camera sees the claw.

The command is :mod:`mearm.maker.calibrate_by_camera`; its rooms, one way down:

- :mod:`.settings`: what the procedure is tuned to (the doubt's priors, the moves'
  margins, the fit's bounds).
- :mod:`.doubt`: how far each servo may be from where it is sent.
- :mod:`.points`: the points over the view and the straight lines in the joints.
- :mod:`.safe_moves`: every move planned in full and checked against the doubt.
- :mod:`.fit_file`: the fit midway between the two arrivals, as the servo file's entries.
- :mod:`.session`: the run on an open rig: the points visited, the looks, the fits.
"""
