"""The reference paper's method and protocol: Newton's search, the 64-case tables, the sensitivity maps."""
