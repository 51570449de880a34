"""Below everything: settings reading and its one error class, package paths, YAML files."""
