"""The Bokeh properties whose change makes BokehJS lay a page out again."""

# BokehJS (3.x) LayoutDOMView.connect_signals: a change of one of these
# lays out the whole layout root again (`invalidate_layout`); `children`
# too (`update_children`).  PlotView: its side panels and renderers lists,
# its frame's size and borders.
LAYOUT_PROPERTIES = {
    "css_classes",
    "stylesheets",
    "width",
    "height",
    "min_width",
    "min_height",
    "max_width",
    "max_height",
    "margin",
    "width_policy",
    "height_policy",
    "flow_mode",
    "sizing_mode",
    "aspect_ratio",
    "visible",
    "resizable",
    "children",
}
PLOT_LAYOUT_PROPERTIES = {
    "above",
    "below",
    "left",
    "right",
    "center",
    "renderers",
    "frame_width",
    "frame_height",
    "frame_align",
    "min_border",
    "min_border_top",
    "min_border_bottom",
    "min_border_left",
    "min_border_right",
}
