"""Self-contained HTML reports: tables, figures embedded as PNG."""
