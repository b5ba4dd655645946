"""marsupial.skills: plug-in skills, one module per skill family."""
