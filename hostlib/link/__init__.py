"""The link to a module: opening a port by path or URL (:mod:`~hostlib.link.connection`), the
protocol without I/O (:class:`~hostlib.link.session.HostSession`), the device with its reader thread
and typed commands (:class:`~hostlib.link.device.Device`), and the state outputs a host asks for
(:mod:`~hostlib.link.outputs`). It knows the step sum, never the fusion."""
