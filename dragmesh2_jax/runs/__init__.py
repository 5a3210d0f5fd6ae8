"""What a run is (spec, folder, record) and the commands that start, resume, load and evaluate runs."""
