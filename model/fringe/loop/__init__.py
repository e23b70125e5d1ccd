"""The closed loop (`fringe loop`), its scenarios and its report."""
