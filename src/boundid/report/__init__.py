"""Layer 6, report: figures, tables and the self-contained HTML pages."""
