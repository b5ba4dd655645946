"""Example marsupial plug-in: a metered hover skill and an altitude condition."""
