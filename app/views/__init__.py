"""The explorer's views: one class per part of the page, fed by the run controller."""
