"""Calibrations a host fits and keeps per module: the magnetometer's hard and soft iron
(:mod:`~hostlib.calibration.magcal`), the in-situ wiggle (:mod:`~hostlib.calibration.wiggle`), the
iron's rotation into the board (:mod:`~hostlib.calibration.iron_rotation`), the hard iron from the
level circle a walk's compass readings draw (:mod:`~hostlib.calibration.level_iron`) and the
closed-loop drift correction (:mod:`~hostlib.calibration.drift`)."""
