"""Fleet analysis: many wells' fit results over time, which changed, when and how."""
