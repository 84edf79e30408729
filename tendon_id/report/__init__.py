"""Human-readable reports: terminal text and self-contained HTML pages."""
