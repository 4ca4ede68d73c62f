"""Every effect of the library, on every shipped machine, gets a widget for each parameter a page shows (the Rotor
page's "Effect switched on", the Diagnose page's "Effect in the sample"): `show_effect` once raised a TypeError in the
server's callback for the bow and the side load, whose node is None until chosen (no default node numbers), and the
page kept the last effect's sliders without a word. Built without a server: the pages' code, not the browser."""

from __future__ import annotations

import panel as pn
import pytest

from lubeviz.app.widgets import show_effect
from lubeviz.effects import EFFECTS
from lubeviz.model.machine import MODELS_DIR, load_machine

MODELS = sorted(MODELS_DIR.glob("*.toml"))


@pytest.fixture(scope="module", params=MODELS, ids=[p.stem for p in MODELS])
def machine(request):
    return load_machine(request.param)


@pytest.mark.parametrize("name", sorted(EFFECTS))
def test_each_effect_shows_a_widget_for_each_of_its_parameters(machine, name):
    story, widgets = pn.pane.Markdown(), pn.Column()
    effect = show_effect(name, machine, story, widgets)
    if effect is None:  # the machine lacks what the effect needs: the story says why, and no stale widget stays
        assert "is not available for this machine" in story.object and not widgets.objects
        return
    names = (*effect.placement, *effect.continuous)
    assert len(widgets.objects) == len(names), (name, names)
    for pname, w in zip(names, widgets.objects):
        assert w.value == getattr(effect, pname) or w.value == pytest.approx(getattr(effect, pname)), (name, pname)


def test_a_place_left_to_the_effect_is_a_choice_the_reader_can_make_and_take_back():
    """The bow's node: None is the first choice, in the doc's words ("the node nearest midway along the span"); a
    node chosen on the widget is the effect's, and None chosen again gives the place back to the effect."""
    machine = load_machine()
    story, widgets = pn.pane.Markdown(), pn.Column()
    effect = show_effect("bow", machine, story, widgets)
    node = widgets.objects[list(effect.placement).index("node")]
    assert isinstance(node, pn.widgets.Select) and node.value is None
    first = next(iter(node.options))
    assert node.options[first] is None and "midway" in first
    assert node.options["12"] == 12 and len(node.options) == machine.n_nodes + 1
    node.value = 12
    assert effect.node == 12 and "node 12" in effect.title()
    node.value = None
    assert effect.node is None
    # the span offers the spans there are, not every node number: on the paper's two bearings the one span is the
    # place left to the effect (between the outermost bearings), on the fan's four supports each of three spans too
    span = widgets.objects[list(effect.placement).index("span")]
    assert list(span.options.values()) == [None]
    fan = load_machine(MODELS_DIR / "three_bearing_fan.toml")
    fan_widgets = pn.Column()
    show_effect("bow", fan, pn.pane.Markdown(), fan_widgets)
    assert list(fan_widgets.objects[1].options.values()) == [None, 1, 2, 3]
