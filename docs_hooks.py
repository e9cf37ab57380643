"""mkdocs hook: publish the pictures that live beside the code that makes them.

`experiments/curricula/curves.png` and `baselines/heatmap.png` are rewritten by `make curricula`
and `make baselines`. The pages link them where they are (`../baselines/heatmap.png`), so that the
links work on the repository's own pages too; the site serves them as `figures/...` and this hook
points those links there, so that they are never copied by hand.
"""

import os
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


def on_page_markdown(markdown, page, config, files):
    """A link to a figure where it lives, e.g. `](../baselines/heatmap.png)`, to where the site serves it."""
    folder = (Path(config["docs_dir"]) / page.file.src_uri).parent
    for uri, source in FIGURES.items():
        here = os.path.relpath(source, folder).replace(os.sep, "/")
        served = os.path.relpath(Path(config["docs_dir"]) / uri, folder).replace(os.sep, "/")
        markdown = markdown.replace(f"]({here})", f"]({served})")
    return markdown
