"""Report stage: one HTML page from the bench and stress documents."""
