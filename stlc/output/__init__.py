"""Output layer: what a compilation writes.

``solution`` holds a solved plan, ``compile`` builds the output files from it,
``directory`` writes them into the output directory, and ``report`` renders the HTML report.
"""
