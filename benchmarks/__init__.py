"""Speed measurements and the papers' benchmarks, run from the repository's root.

``python -m benchmarks.<name>`` or ``python benchmarks/<name>.py``; each prints its tables and writes its JSON
under ``benchmarks/out/``.
"""
