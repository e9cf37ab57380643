"""mkdocs hook: publish the pictures that live beside the code that makes them.

`experiments/curricula/curves.png` and `baselines/heatmap.png` are rewritten by `make curricula`
and `make baselines`; the site serves them as `figures/...` so that they are never copied by hand.
"""

from pathlib import Path

from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parent
FIGURES = {
    "figures/curricula-curves.png": ROOT / "experiments" / "curricula" / "curves.png",
    "figures/baselines-heatmap.png": ROOT / "baselines" / "heatmap.png",
}


def on_files(files, config):
    for uri, source in FIGURES.items():
        if not source.is_file():
            raise FileNotFoundError(f"docs figure {uri}: its source {source} does not exist")
        files.append(File.generated(config, uri, abs_src_path=str(source)))
    return files
