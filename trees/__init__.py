"""marsupial.trees: the mission runtime (YAML -> py_trees, runner, recorder, replay)."""
