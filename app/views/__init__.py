"""The explorer's views: each a Panel Viewer fed by a run (or a map), with no
knowledge of the controller that feeds it."""
