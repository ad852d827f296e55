"""The limit search: self-weight first, then the live load raised until no equilibrium exists."""
