"""The vibtrans explorer (Panel): layout, widgets and callbacks only."""
