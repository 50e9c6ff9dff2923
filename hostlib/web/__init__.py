"""Live pages: a walk shown in a browser while it goes (``openshoe-host track --web [HOST:]PORT``).

* :mod:`.address` — where a page listens (loopback unless a host is named);
* :mod:`.model` — what a page shows, in bounded series and values, and the messages that keep a
  page in step with it;
* :mod:`.server` — the small HTTP server (aiohttp, in a thread of its own): the page, its scripts
  from this package's ``static`` folder (nothing from the network), server-sent events;
* :mod:`.feed` — a :class:`~hostlib.run.tracking_run.TrackingRun` turned into a model as its steps
  come;
* :mod:`.walk_page` — the two put together for ``track --web``.

The emulator's panel (:mod:`firmware_sim.app.web`) is served by the same server and draws with
the same script (``static/live.js``). Only the server needs aiohttp (the ``web`` extra); this
package's other modules import without it.
"""
