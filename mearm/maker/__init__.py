"""The maker's commands: from a new board, arm and camera to a working config."""
