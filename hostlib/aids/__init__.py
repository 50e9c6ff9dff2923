"""What the aids measure, before any filter: the per-step compass heading from a stance's
magnetometers (:mod:`~hostlib.aids.compass`), the World Magnetic Model's declination
(:mod:`~hostlib.aids.declination`), GPS fixes read from NMEA (:mod:`~hostlib.aids.gps`) and the
geodesy that places them (:mod:`~hostlib.aids.geodesy`)."""
