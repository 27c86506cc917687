"""The run's buttons and progress, views of the session's RunController:
Run (the state's scene), Cancel (enabled while a run is busy) and the
progress bar (shown while it is)."""

import panel as pn


class RunButtons:
    """RunButtons(controller, run, answered): `run()` starts the state's
    scene; `answered()` clears the browser's acknowledgement (the progress
    bar says the click was heard)."""

    def __init__(self, controller, run, answered):
        self.controller, self.answered = controller, answered
        self.progress = pn.indicators.Progress(
            value=0, max=100, visible=False, sizing_mode="stretch_width", label="progress"
        )
        self.cancel_button = pn.widgets.Button(label="Cancel", color="warning", disabled=True)
        self.cancel_button.on_click(lambda event: controller.cancel())
        self.run_button = pn.widgets.Button(
            label="Run selected scene", color="primary", css_classes=["vt-run", "vt-ack-run"]
        )
        self.run_button.on_click(lambda event: run())
        controller.param.watch(self._on_busy, "busy")
        controller.param.watch(self._on_progress, "progress")

    def _on_busy(self, event):
        with pn.io.hold():
            self.progress.visible = event.new
            self.cancel_button.disabled = not event.new
            self.answered()  # the progress bar says it now

    def _on_progress(self, event):
        self.progress.value = int(100 * event.new)
