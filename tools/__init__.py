"""sportfusion command-line tools: one thin click command per file."""
