"""``openshoe-emu serve --web [HOST:]PORT``: the served modules' live panel (:mod:`.panel`), drawn by
``static/emu.js`` with the walk page's shared script and server (:mod:`hostlib.web`)."""
