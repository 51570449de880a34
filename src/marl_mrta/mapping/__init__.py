"""Maps: digitising building geometry (SDF) into map_server maps, and reading those maps."""
