"""A servo calibration measured on the virtual Uno says it is simulated.

``mearm calibrate-servos --config my_arm.yaml --set servo.backend=virtual_uno`` wrote
``board_id: mearm_servo 2.0 5`` and ``port: /dev/pts/1``: the file of a simulated arm
read as a real Uno's (``--simulate`` writes ``simulated: the MuJoCo twin …``). The board
is the real firmware in simavr, connected as the command connects it.
"""

from __future__ import annotations

from conftest import missing_tool

from mearm.config import load_config
from mearm.maker.calibrate_servos import open_arm_bus
from mearm.maker.servo_output import board_identity
from mearm.sim.virtual_uno import missing_requirements


def test_the_virtual_unos_identity_is_simulated_with_its_firmware_and_no_port():
    missing = missing_requirements()
    if missing:
        missing_tool(", ".join(f"{r.what} ({r.package})" for r in missing))
    config = load_config("sim_mearm_v1", ["servo.backend=virtual_uno"])
    with open_arm_bus(config) as bus:
        board, port = board_identity(bus)
    assert board.startswith("simulated: the virtual Uno, the firmware in simavr (mearm_servo ")
    assert port == ""
