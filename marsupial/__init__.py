"""marsupial: behaviour-tree missions for marsupial robot teams (carrier + child robots)."""

__version__ = "0.1.0"
