"""Carrying out a walk: the aids set up from what a user has (:mod:`~hostlib.run.aid_setup`) and a
GPS receiver read live (:mod:`~hostlib.run.gps_stream`)."""
