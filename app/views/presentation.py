"""Presentation mode: a projector's sizes.  On the server, the figures'
fonts (`scale_fonts`) and Bokeh's widget font (a CSS property the page's
parts inherit, set by the page); in the browser, the root font size and the
sidebar's width (app/views/browserside.py: Bootstrap sizes its buttons and inputs
in rem, which no property of a part reaches)."""

import panel as pn
from bokeh.models import ColorBar, Legend, Title

# the page's text, its widgets and the figures' fonts this much larger
PRESENTATION_SCALE = 1.5
BOKEH_FONT_PX = 12  # Bokeh's widgets' font size (its --bokeh-font-size default)
SIDEBAR_WIDTH = 330  # px
# In presentation mode the sidebar grows with its text, to at most this
# share of the screen's width (vw): at 1024 pixels a sidebar of 1.5 x 330
# left the map half its room and cut the run's figures' titles
PRESENTATION_SIDEBAR_VW = 35
# Tabs whose headers wrap onto a second row where they do not fit (large
# fonts in half a screen) instead of scrolling sideways, cut off
WRAPPING_TABS = ".bk-headers-wrapper { flex-wrap: wrap; }"
# A button group's labels wrap inside their buttons where the group is
# narrower than its labels on one line (large fonts in the sidebar), instead
# of running out of the sidebar
WRAPPING_BUTTONS = ".bk-btn-group > .bk-btn { white-space: normal; }"
# A widget's label wraps where it is wider than the widget (Bokeh keeps it on
# one line, cut: "exponent N (≥ 1; 1 the cone, 2 the sp" in the sidebar)
WRAPPING_LABELS = ".bk-input-group > label { white-space: normal; }"
# The text in text inputs and selects: the browser's own size for a form's
# controls (13.33 px, not inherited, so presentation mode left the typed
# log10 A* and the chosen mu at it beside 18-pixel labels), in rem so that
# it follows the page's root size as Bootstrap's paddings do
INPUT_FONT = "input.bk-input, select.bk-input, textarea.bk-input { font-size: 0.8333rem; }"


class ExplorerDesign(pn.theme.Bootstrap):
    """Panel's Bootstrap design with INPUT_FONT in every widget (a design's
    modifiers, Panel's public way to style each component of a page, the
    Units and Design tabs' forms built later included)."""

    # Inherit: the design's own stylesheets first (without it, a modifier
    # replaces them, and the widgets lost Bootstrap's look)
    modifiers = {
        pn.widgets.Widget: {"stylesheets": [pn.theme.Inherit, INPUT_FONT, WRAPPING_LABELS]},
        pn.widgets.RadioButtonGroup: {
            "stylesheets": [pn.theme.Inherit, INPUT_FONT, WRAPPING_LABELS, WRAPPING_BUTTONS]
        },
    }


# the widgets whose own width `scale_widths` scales (text boxes and
# selects, whose text grows; not sliders, which would outgrow their rows)
SCALED_WIDGETS = (pn.widgets.Select, pn.widgets.TextInput)


def scale_widths(viewable, factor, widths):
    """Set the widgets under `viewable` that have a width of their own (a
    select or text box, `SCALED_WIDGETS`) to `factor` times that width, so
    that their text, which grows with the page's in presentation mode, keeps
    its room; factor 1 restores them.  widths: {id: (widget, own width)},
    where each widget's own width is remembered when first seen."""
    for w in viewable.select(pn.widgets.Widget):
        if not isinstance(w, SCALED_WIDGETS) or w.width is None or w.sizing_mode not in (None, "fixed"):
            continue
        own = widths.setdefault(id(w), (w, w.width))[1]
        w.width = round(own * factor)


def scale_fonts(fig, factor):
    """Set a Bokeh figure's text to `factor` times Bokeh's default sizes
    (titles, axis labels and ticks, legends); factor 1 restores them."""
    if getattr(fig, "renderers", None) is None:  # a layout: its children
        for child in getattr(fig, "children", []):
            scale_fonts(child[0] if isinstance(child, tuple) else child, factor)
        return

    def size(points):
        return f"{points * factor:.3g}pt"

    if isinstance(getattr(fig, "title", None), Title):
        fig.title.text_font_size = size(10)
    # the figure's other titles (notes above or below its frame), a size smaller
    for item in [*fig.above, *fig.below]:
        if isinstance(item, Title) and item is not fig.title:
            item.text_font_size = size(8.5)
    for axis in [*fig.xaxis, *fig.yaxis]:
        axis.axis_label_text_font_size = size(10)
        axis.major_label_text_font_size = size(8)
    for item in [*fig.left, *fig.right, *fig.above, *fig.below, *fig.center]:
        if isinstance(item, Legend):
            item.label_text_font_size = size(9)
        elif isinstance(item, ColorBar):
            item.title_text_font_size = size(10)
            item.major_label_text_font_size = size(8)
