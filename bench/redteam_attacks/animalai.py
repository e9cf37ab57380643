"""The import-animalai group: source names of every odd kind, links and pipes in the source folder,
a huge sparse file, other encodings and a ``!!python`` tag."""

from __future__ import annotations

import os

from .base import AAAI, ROOT, attack
from .inputs import both, fifo, link, text, unchanged, victim

GROUP = "import-animalai"


def imports(source):
    return [AAAI, "import-animalai", source, "--out", "out"]


def inside_out(w, r):
    inside = all(p.resolve().is_relative_to((w / "out").resolve()) for p in (w / "out").rglob("*"))
    return None if inside else "wrote outside --out"


def sparse(w):
    (w / "big.yaml").touch()
    os.truncate(w / "big.yaml", 2 << 30)


def python_tag(w):
    (w / "a.yaml").write_text(f"!!python/object/apply:os.system ['touch {w.parent}/CANARY']\n")


def attacks():
    good = (ROOT / "tests/fixtures/animalai").glob("*.y*ml")
    sample = next(iter(sorted(good))).read_text()
    names = {
        "unicode": "арена ü.yaml",
        "newline": "a\nb.yaml",
        "rtl": "x\u202elmay.yaml",
        "dash": "-x.yaml",
        "dots": "...yaml",
        "spaces": "   .yaml",
    }
    for kind, name in names.items():
        attack(f"import-name-{kind}", GROUP, imports("src"), text("src/" + name, sample), "any", check=inside_out)
    loop = both(text("src/a.yaml", sample), link("src/loop", "{W}/src"))
    attack("import-symlink-dir-loop", GROUP, imports("src"), loop, "any", timeout=30)
    out = both(victim("secret.yaml", sample), link("src/a.yaml", "{O}/secret.yaml"))
    attack("import-symlink-file-out", GROUP, imports("src"), out, "any", check=unchanged("secret.yaml", sample))
    pipe = both(text("src/a.yaml", sample), fifo("src/b.yaml"))
    attack("import-fifo-in-folder", GROUP, imports("src"), pipe, "any", timeout=30)
    attack("import-sparse-2gb", GROUP, imports("big.yaml"), sparse, "error")
    attack("import-utf16", GROUP, imports("a.yaml"), text("a.yaml", sample, "utf-16"), "error")
    attack("import-bom", GROUP, imports("a.yaml"), text("a.yaml", "\ufeff" + sample), "any")
    attack("import-python-tag-canary", GROUP, imports("a.yaml"), python_tag, "error")
