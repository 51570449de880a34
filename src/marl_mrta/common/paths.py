"""Where the package's files are: the package root, its config files, a scenario's resources."""
from __future__ import annotations

from pathlib import Path


def package_root() -> Path:
    """The marl_mrta package directory (source checkout or installed share directory)."""
    checkout = Path(__file__).resolve().parents[3]   # <root>/src/marl_mrta/common/this file
    if (checkout / "package.xml").is_file():
        return checkout
    import rospkg  # an installed package: ask ROS where its share directory is
    return Path(rospkg.RosPack().get_path("marl_mrta"))


def runs_dir() -> Path:
    """Where a user's runs go when no --out names a place: results/runs/ (git-ignored). results/
    itself holds the benchmarks' files, from which docs/results.md is generated."""
    return package_root() / "results" / "runs"


def default_config_path(name: str) -> Path:
    """config/<name> of the package."""
    return package_root() / "config" / name


def resolve_resource(reference: str, relative_to: Path) -> Path:
    """A file reference of a scenario: package://<pkg>/<path>, absolute, or relative to `relative_to`.
    ValueError when ROS knows no package <pkg>."""
    prefix = "package://"
    if reference.startswith(prefix):
        package, _, rest = reference[len(prefix):].partition("/")
        if package == "marl_mrta":
            return package_root() / rest
        import rospkg  # other packages: only ROS knows where they are
        try:
            return Path(rospkg.RosPack().get_path(package)) / rest
        except rospkg.ResourceNotFound:
            raise ValueError(f"{reference}: ROS knows no package '{package}'") from None
    path = Path(reference)
    return path if path.is_absolute() else relative_to / path
