"""marsupial.api: the plug-in contract between the world, the runtime and the skills (no simulator imports)."""
