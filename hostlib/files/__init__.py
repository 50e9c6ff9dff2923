"""Tracks in and out of files: CSV and GeoJSON (:mod:`~hostlib.files.export`), PNG pictures
(:mod:`~hostlib.files.plot`) and the replay of recorded wire captures (:mod:`~hostlib.files.replay`)."""
