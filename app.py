"""lubeviz dashboard: `panel serve app.py`. Assembles the views of lubeviz.app; holds no numerics."""

import panel as pn

from lubeviz.app.shell import build

build().servable()
