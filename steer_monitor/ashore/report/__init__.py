"""Reports people read: self-contained HTML pages with PNG plots (matplotlib, Agg)."""
