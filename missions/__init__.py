"""marsupial.missions: the YAML missions shipped with the package."""
