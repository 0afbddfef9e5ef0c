"""The shape of the house: one-way imports, no cycles, no private names across modules, parallel
machinery in the runtime core only, and modules and functions small enough to read."""

from __future__ import annotations

import ast
import re
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("libero_data", "libero_bench")
#: Guides with some slack (ARCHITECTURE.md: modules ~400 lines, functions ~80).
MOST_MODULE_LINES = 450
MOST_FUNCTION_LINES = 100


def _modules() -> dict[str, Path]:
    found = {}
    for package in PACKAGES:
        for path in (ROOT / package).rglob("*.py"):
            parts = list(path.relative_to(ROOT).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            found[".".join(parts)] = path
    return found


MODULES = _modules()


def _owner(name: str) -> str | None:
    """The project module a dotted name lives in (a module, or an attribute of one)."""
    while name and name not in MODULES:
        name = name.rpartition(".")[0]
    return name or None


def _imports() -> tuple[dict[str, set[str]], list[str]]:
    """Every import between project modules (lazy and type-only ones too), and private names
    imported from another module."""
    graph: dict[str, set[str]] = defaultdict(set)
    private = []
    for module, path in MODULES.items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] in PACKAGES:
                for alias in node.names:
                    full = f"{node.module}.{alias.name}"
                    target = full if full in MODULES else _owner(node.module)
                    if target and target != module:
                        graph[module].add(target)
                    if alias.name.startswith("_") and full not in MODULES and node.module != module:
                        private.append(f"{module} imports {node.module}.{alias.name}")
            elif isinstance(node, ast.Import):
                for alias in node.names:
                    target = _owner(alias.name) if alias.name.split(".")[0] in PACKAGES else None
                    if target and target != module:
                        graph[module].add(target)
    return graph, private


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected groups of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                found.append(sorted(group))

    for module in sorted(MODULES):
        if module not in index:
            visit(module)
    return found


def test_no_import_cycles_and_no_private_names_across_modules() -> None:
    graph, private = _imports()
    assert _cycles(graph) == []
    assert private == []


def _public_definitions(path: Path) -> list[str]:
    tree = ast.parse(path.read_text())
    return [
        node.name
        for node in tree.body
        if isinstance(node, ast.FunctionDef | ast.ClassDef) and not node.name.startswith("_")
    ]


def test_no_name_is_used_for_two_things() -> None:
    """Within a package, a public function or class is defined in one module only, and no two
    modules share a file name, except where a layout is repeated on purpose: one module per
    command in ``cli/``, ``config.py``/``model.py`` per policy, ``base.py`` per registry."""
    repeated_on_purpose = {"config", "model", "base"}
    defined: dict[str, list[str]] = defaultdict(list)
    files: dict[str, list[str]] = defaultdict(list)
    for module, path in MODULES.items():
        package = module.split(".")[0]
        for name in _public_definitions(path):
            defined[f"{package}: {name}"].append(module)
        stem = path.stem
        if stem != "__init__" and ".cli." not in f".{module}." and stem not in repeated_on_purpose:
            files[f"{package}: {stem}.py"].append(module)
    twice = {name: where for name, where in defined.items() if len(where) > 1}
    assert twice == {}
    same_file = {name: where for name, where in files.items() if len(where) > 1}
    assert same_file == {}


def _edges(source: str, target: str) -> list[str]:
    """Imports (lazy and type-only ones too) from modules under ``source`` to ones under ``target``."""
    graph, _ = _imports()
    return sorted(
        f"{m} -> {t}" for m, ts in graph.items() if m.startswith(source) for t in ts if t.startswith(target)
    )


#: Each package's rooms (subpackages, and top-level modules), in the direction data flows: a room
#: imports only rooms before it (ARCHITECTURE.md, "Rooms"). A new room takes its place here.
ROOMS = {
    "libero_data": (
        "errors",
        "config",
        "registry",
        "numerics",
        "runtime",
        "seeding",
        "stats",
        "bddl",
        "tasks",
        "scenes",
        "perturb",
        "sim",
        "provenance",
        "rollout",
        "initial_scene",
        "experts",
        "record",
        "hdf5",
        "procedural",
        "cards",
        "pipeline",
        "cli",
    ),
    "libero_bench": (
        "sizes",
        "data",
        "policies",
        "algos",
        "runs",
        "rollouts",
        "rl",
        "train",
        "evaluation",
        "analysis",
        "robustness",
        "registry_docs",
        "cli",
    ),
}


def _room(module: str) -> tuple[str, str]:
    package, _, rest = module.partition(".")
    return package, rest.split(".")[0] if rest else ""


def test_every_room_has_its_place() -> None:
    rooms = {_room(m) for m in MODULES if "." in m}
    assert sorted(r for r in rooms if r[1] not in ROOMS[r[0]]) == []


def test_rooms_import_one_way() -> None:
    """A room imports only the rooms before it in :data:`ROOMS`, lazy and type-only imports too."""
    graph, _ = _imports()
    against = []
    for module, targets in graph.items():
        package, room = _room(module)
        order = ROOMS[package]
        for target in targets:
            other_package, other = _room(target)
            same_package = other_package == package and other != room and room and other
            if same_package and order.index(other) > order.index(room):
                against.append(f"{module} -> {target}")
    assert sorted(against) == []


def test_data_never_imports_the_benchmark() -> None:
    assert _edges("libero_data", "libero_bench") == []


def test_process_pools_and_ray_live_in_the_runtime_core_only() -> None:
    forbidden = (
        "import multiprocessing",
        "from multiprocessing",
        "ProcessPoolExecutor",
        "import ray",
        "ray.remote",
    )
    offenders = []
    for module, path in MODULES.items():
        if module.startswith("libero_data.runtime"):
            continue
        text = path.read_text()
        offenders += [f"{module}: {word}" for word in forbidden if word in text]
    assert offenders == []


def test_modules_and_functions_stay_readable() -> None:
    long_modules = []
    long_functions = []
    for module, path in MODULES.items():
        text = path.read_text()
        if len(text.splitlines()) > MOST_MODULE_LINES:
            long_modules.append(f"{module}: {len(text.splitlines())} lines")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                lines = (node.end_lineno or node.lineno) - node.lineno + 1
                if lines > MOST_FUNCTION_LINES:
                    long_functions.append(f"{module}.{node.name}: {lines} lines")
    assert long_modules == []
    assert long_functions == []


def test_nothing_we_open_is_unpickled() -> None:
    """Checkpoints, run folders, datasets and messages are opened without unpickling; only
    libero_bench.runs.migrate reads an earlier version's pickles, with torch's restricted loader."""
    forbidden = re.compile(
        r"weights_only\s*=\s*False|pickle\.loads?\(|allow_pickle\s*=\s*True|cloudpickle|\bdill\b|"
        r"joblib|read_pickle|np\.load\([^)]*allow_pickle\s*=\s*True|torch\.load\("
    )
    sources = [*MODULES.values(), *sorted((ROOT / "plugins").rglob("*.py"))]
    offenders = []
    for path in sources:
        for number, line in enumerate(path.read_text().splitlines(), 1):
            found = forbidden.search(line)
            allowed = path.name == "migrate.py" and "torch.load(" in line and "weights_only=True" in line
            if found and not allowed:
                offenders.append(f"{path.relative_to(ROOT)}:{number}: {line.strip()}")
    assert offenders == []


#: class names that say "this is a config" (settings a user or a file gives)
CONFIG_SUFFIXES = ("Config", "Request", "Options", "Settings", "Preset")


def test_every_config_is_on_the_config_base() -> None:
    bases: dict[str, list[str]] = {}
    for path in MODULES.values():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ClassDef):
                bases[node.name] = [
                    b.id if isinstance(b, ast.Name) else getattr(b, "attr", "") for b in node.bases
                ]

    def on_base(name: str, seen: frozenset[str] = frozenset()) -> bool:
        if name == "Config":
            return True
        return any(on_base(b, seen | {name}) for b in bases.get(name, []) if b not in seen)

    outside = sorted(n for n in bases if n.endswith(CONFIG_SUFFIXES) and n != "Config" and not on_base(n))
    assert outside == []


def test_registered_configs_need_no_torch() -> None:
    """Policies, algorithms and robustness kinds are found through their configs, which load
    without torch (the models load when one is built)."""
    import subprocess
    import sys

    code = (
        "import sys\n"
        "from libero_bench.policies import policy_names, policy_config\n"
        "from libero_bench.algos import algo_names, algo_config\n"
        "from libero_data.perturb.kinds import all_kinds\n"
        "assert policy_names() and algo_names() and all_kinds()\n"
        "[policy_config(n, 'smoke') for n in policy_names()]\n"
        "[algo_config(n, 'smoke') for n in algo_names()]\n"
        "print('torch' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert out.stdout.strip() == "False"


def _assigned_names(path: Path) -> list[str]:
    names = []
    for node in ast.parse(path.read_text()).body:
        targets = (
            node.targets
            if isinstance(node, ast.Assign)
            else [node.target]
            if isinstance(node, ast.AnnAssign)
            else []
        )
        names += [t.id for t in targets if isinstance(t, ast.Name)]
    return names


def test_old_files_are_read_one_way() -> None:
    """What earlier versions wrote is declared on the config that reads it (``legacy``), not in
    module-level tables beside it."""
    found = [
        f"{m}: {n}" for m, path in MODULES.items() for n in _assigned_names(path) if n.startswith("LEGACY")
    ]
    assert found == []


def test_the_simulator_applies_perturbations_and_perturbations_need_no_simulator() -> None:
    """One direction: ``sim`` calls the kinds' hooks (``perturb.apply``); no kind, nor anything
    else in ``perturb``, imports ``sim`` (contact sheets that render live in ``procedural``)."""
    assert _edges("libero_data.perturb", "libero_data.sim") == []
