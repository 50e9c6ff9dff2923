"""Calibrations a host fits and keeps per module: the magnetometer's hard and soft iron
(:mod:`~hostlib.calibration.magcal`), the in-situ wiggle (:mod:`~hostlib.calibration.wiggle`), the
iron's rotation into the board (:mod:`~hostlib.calibration.iron_rotation`) and the closed-loop drift
correction (:mod:`~hostlib.calibration.drift`)."""
