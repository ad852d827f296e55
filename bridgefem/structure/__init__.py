"""The structure a scene describes: its blocks and joints, supports and their movements."""
