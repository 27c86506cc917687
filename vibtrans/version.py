"""The installed package's version (results and stores record it), in a
module of its own so that any layer may read it without importing the
package's re-exports of every layer."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("vibtrans")
except PackageNotFoundError:  # pragma: no cover - source tree without install
    __version__ = "0+unknown"
