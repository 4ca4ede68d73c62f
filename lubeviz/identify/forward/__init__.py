"""The forward model: supply flows and effect parameters -> what the probes read, and its uncertainty."""
