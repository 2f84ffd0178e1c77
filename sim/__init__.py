"""The World and what it needs from every package: runtime set-up, precision, errors, stores."""
