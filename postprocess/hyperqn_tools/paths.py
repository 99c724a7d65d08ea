"""Where the repository and the shared meshes are."""
import os

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
SHARED_MESHES = os.path.abspath(os.path.join(REPO, "..", "shared", "meshes"))
