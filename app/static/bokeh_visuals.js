// Two reads of BokehJS 3.9 that make the browser recompute the page's styles
// many times while it lays out and paints plots (in a profile of the
// explorer's first point-mass run: over half of the browser's time).
//
// 1. Every visual property (line, fill, text, hatch) of every glyph, axis,
//    legend and colour bar is read from the CSS cascade first
//    (getComputedStyle(el).getPropertyValue("--bk-...")), the model's value
//    used when that is "".  No stylesheet of this page defines a --bk-*
//    property (tests/test_app_browser.py checks the page), so the read is
//    always "": answering "" at once draws the same.
// 2. A plot's base font size (getComputedStyle(el).fontSize, for labels in
//    em) is read for every label set of every axis; it is read once per
//    plot and task here (the next task reads it again).
//
// Upstream: bokeh/bokeh#15286 (and #15205, which caches the CSS reads
// within a task).  Another BokehJS version is left as it is.
(function () {
  const Bokeh = window.Bokeh;
  if (Bokeh == null || typeof Bokeh.require !== "function"
      || !/^3\.9\./.test(String(Bokeh.version)))
    return;
  const done = [];
  try {
    const visuals = Bokeh.require("core/visuals/visual");
    const proto = visuals.VisualProperties && visuals.VisualProperties.prototype;
    if (proto && typeof proto._get_css_value === "function") {
      proto._get_css_value = function () { return ""; };
      done.push("visuals from the models");
    }
  } catch (e) { /* a BokehJS without that module: unchanged */ }
  try {
    const plot = Bokeh.require("models/plots/plot");
    const proto = plot.PlotView && plot.PlotView.prototype;
    const desc = proto && Object.getOwnPropertyDescriptor(proto, "base_font_size");
    if (desc && typeof desc.get === "function") {
      const read = desc.get;
      Object.defineProperty(proto, "base_font_size", {
        configurable: true,
        get() {
          if (this.__vtFontSize === undefined) {
            this.__vtFontSize = read.call(this);
            setTimeout(() => { this.__vtFontSize = undefined; }, 0);
          }
          return this.__vtFontSize;
        },
      });
      done.push("font size once per task");
    }
  } catch (e) { /* unchanged */ }
  window.__vtBokehReads = done.join(", ");
})();
