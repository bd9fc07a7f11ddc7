# SPDX-License-Identifier: Apache-2.0
"""Train the five Siamese embedding nets of paper 004 Section 3.2.1 (compact CPU variant) and export ONNX.

Run in the training-only venv (torch is not a runtime dependency):
    python3 -m venv .venv-train && .venv-train/bin/pip install -r requirements-train.txt
    nice .venv-train/bin/python training/train_siamese.py            # writes swir_tracker_ros/models/
    .venv-train/bin/python training/train_siamese.py --verify        # onnxruntime vs torch embeddings
Fixed seeds and a fixed thread count make a rerun on the same machine reproduce the shipped weights.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time
from pathlib import Path

import numpy as np
import torch
from torch import nn

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "training"))

from data import RAW, training_set, validation_set  # noqa: E402

from swir_tracker_ros.acquisition.siamese import (  # noqa: E402
    INPUT_SIZE,
    MODELS_DIR,
    NET_NAMES,
    SiameseFamily,
    split_quadrants,
    standardise,
)

SEED = 20211130
THREADS = 2
# Compact variant of the paper's nets (96/128/12 whole, 112/96/12 parts): same 3 conv + 3 pool + 2 FC layout,
# about 1/6 of the filters, input 64x64 (quadrants 32x32) instead of 200x200 (notes seed-004 Section 6).
WHOLE = {"filters": (16, 24, 12), "embed": 50}
PART = {"filters": (16, 16, 12), "embed": 30}


class Embedding(nn.Module):
    """conv3x3, ReLU, maxpool2, dropout 0.25 (three times); FC128, ReLU, dropout 0.1; FC(d), ReLU."""

    def __init__(self, size: int, filters: tuple[int, int, int], embed: int) -> None:
        super().__init__()
        layers: list[nn.Module] = []
        c, s = 1, size
        for f in filters:
            layers += [nn.Conv2d(c, f, 3), nn.ReLU(), nn.MaxPool2d(2), nn.Dropout(0.25)]
            c, s = f, (s - 2) // 2
        self.features = nn.Sequential(*layers)
        self.head = nn.Sequential(nn.Flatten(), nn.Linear(c * s * s, 128), nn.ReLU(), nn.Dropout(0.1),
                                  nn.Linear(128, embed), nn.ReLU())

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.head(self.features(x))


def make_nets() -> list[Embedding]:
    return [Embedding(INPUT_SIZE, WHOLE["filters"], WHOLE["embed"])] + [
        Embedding(INPUT_SIZE // 2, PART["filters"], PART["embed"]) for _ in range(4)
    ]


def contrastive(d: torch.Tensor, same: torch.Tensor, margin: float = 1.0) -> torch.Tensor:
    """Hadsell et al. contrastive loss with margin 1 (paper 004 eq. 4 with the label convention corrected:
    same = 1 pulls a pair together, same = 0 pushes it beyond the margin)."""
    return 0.5 * (same * d**2 + (1 - same) * torch.clamp(margin - d, min=0) ** 2).mean()


def augment(raw: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Random 64x64 window of the 72x72 crop (box jitter), flip, contrast, Gaussian and salt-pepper noise."""
    off = rng.integers(0, RAW - INPUT_SIZE + 1, size=2)
    p = raw[off[0] : off[0] + INPUT_SIZE, off[1] : off[1] + INPUT_SIZE].astype(np.float32)
    if rng.random() < 0.5:
        p = p[:, ::-1]
    p = p * rng.uniform(0.7, 1.3) + rng.normal(0, rng.uniform(0, 6), p.shape)
    if rng.random() < 0.3:
        sp = rng.random(p.shape)
        p[sp < 0.005] = 0
        p[sp > 0.995] = 255
    return standardise(np.clip(p, 0, 255))


def centre(raw: np.ndarray) -> np.ndarray:
    o = (RAW - INPUT_SIZE) // 2
    return standardise(raw[o : o + INPUT_SIZE, o : o + INPUT_SIZE].astype(np.float32))


def sample_pairs(data: dict[str, list[np.ndarray]], n: int, rng: np.random.Generator, aug: bool):
    """n balanced pairs: half the same identity, half two different identities."""
    keys = [k for k, v in data.items() if len(v) >= 2]
    a, b, same = [], [], []
    for i in range(n):
        k1 = keys[rng.integers(len(keys))]
        if i % 2 == 0:
            k2 = k1
        else:
            k2 = keys[rng.integers(len(keys))]
            while k2 == k1:
                k2 = keys[rng.integers(len(keys))]
        x1 = data[k1][rng.integers(len(data[k1]))]
        x2 = data[k2][rng.integers(len(data[k2]))]
        f = (lambda r: augment(r, rng)) if aug else centre
        a.append(f(x1))
        b.append(f(x2))
        same.append(1.0 if k1 == k2 else 0.0)
    return np.stack(a), np.stack(b), np.array(same, np.float32)


def inputs(batch: np.ndarray) -> list[torch.Tensor]:
    """Whole patches and their four quadrants as NCHW tensors, in NET_NAMES order."""
    quads = [split_quadrants(p) for p in batch]
    out = [torch.from_numpy(np.ascontiguousarray(batch[:, None]))]
    for i in range(4):
        out.append(torch.from_numpy(np.ascontiguousarray(np.stack([q[i] for q in quads])[:, None])))
    return out


def pair_accuracy(nets: list[Embedding], pairs, threshold: float = 0.5) -> list[float]:
    a, b, same = pairs
    with torch.no_grad():
        accs = []
        for net, xa, xb in zip(nets, inputs(a), inputs(b)):
            d = torch.linalg.norm(net(xa) - net(xb), dim=1).numpy()
            accs.append(float(np.mean((d < threshold) == (same > 0.5))))
    return accs


def train(shared: Path, out_dir: Path, steps: int, batch: int) -> dict:
    torch.manual_seed(SEED)
    torch.set_num_threads(THREADS)
    torch.use_deterministic_algorithms(True)
    rng = np.random.default_rng(SEED)
    data = training_set(shared, SEED)
    val = validation_set(shared, SEED)
    val_pairs = sample_pairs(val, 400, np.random.default_rng(SEED + 2), aug=False)
    nets = make_nets()
    params = [p for n in nets for p in n.parameters()]
    opt = torch.optim.RMSprop(params, lr=5e-4)  # paper 004: RMSprop, lr 0.0005
    t0 = time.time()
    for step in range(steps):
        for n in nets:
            n.train()
        a, b, same = sample_pairs(data, batch, rng, aug=True)
        y = torch.from_numpy(same)
        loss = sum(contrastive(torch.linalg.norm(net(xa) - net(xb), dim=1), y)
                   for net, xa, xb in zip(nets, inputs(a), inputs(b)))
        opt.zero_grad()
        loss.backward()
        opt.step()
        if step % 50 == 0 or step == steps - 1:
            for n in nets:
                n.eval()
            acc = pair_accuracy(nets, val_pairs)
            accs = " ".join(f"{x:.3f}" for x in acc)
            print(f"step {step:4d} loss {float(loss.detach()):.4f} val acc {accs} ({time.time() - t0:.0f} s)",
                  flush=True)
    for n in nets:
        n.eval()
    acc = pair_accuracy(nets, val_pairs)
    out_dir.mkdir(parents=True, exist_ok=True)
    files = {}
    for name, net in zip(NET_NAMES, nets):
        size = INPUT_SIZE if name == "whole" else INPUT_SIZE // 2
        path = out_dir / f"siamese_{name}.onnx"
        torch.onnx.export(net, (torch.zeros(1, 1, size, size),), str(path), input_names=["patch"],
                          output_names=["embedding"], dynamic_axes={"patch": {0: "n"}, "embedding": {0: "n"}},
                          opset_version=13, dynamo=False)
        files[path.name] = hashlib.sha256(path.read_bytes()).hexdigest()
    meta = {
        "description": "Siamese embedding nets of paper 004 Section 3.2.1, compact CPU variant",
        "nets": list(NET_NAMES),
        "input_size": INPUT_SIZE,
        "input_normalisation": "crop resized to input_size^2 (INTER_AREA), then zero mean / unit std",
        "whole": WHOLE,
        "part": PART,
        "loss": "contrastive, margin 1", "optimiser": "RMSprop lr 5e-4",
        "steps": steps, "batch_pairs": batch, "seed": SEED, "threads": THREADS,
        "torch": torch.__version__,
        "training_identities": len(data), "training_crops": int(sum(len(v) for v in data.values())),
        "sources": ["mot/tud_campus gt (ids 3, 7 held out)", "reid/vottir2016_crowd",
                    "sequences/otb_crossing, otb_jogging-1, otb_walking2, ptbtir_airplane",
                    "acquisition.crowd synthetic identities (48 x 16)"],
        "validation": "400 balanced pairs, TUD ids 3 and 7 + 12 unseen synthetic identities, D < 0.5 = same",
        "validation_pair_accuracy": dict(zip(NET_NAMES, (round(x, 4) for x in acc))),
        "sha256": files,
        "command": "nice .venv-train/bin/python training/train_siamese.py",
    }
    (out_dir / "siamese.json").write_text(json.dumps(meta, indent=2) + "\n")
    return meta


def load_from_onnx(model_dir: Path) -> list[Embedding]:
    """Torch nets whose weights are read back from the exported ONNX initialisers."""
    import onnx
    from onnx import numpy_helper

    nets = make_nets()
    for name, net in zip(NET_NAMES, nets):
        model = onnx.load(str(model_dir / f"siamese_{name}.onnx"))
        inits = {i.name: numpy_helper.to_array(i) for i in model.graph.initializer}
        state = {k: torch.from_numpy(np.array(inits[k])) for k in net.state_dict()}
        net.load_state_dict(state)
        net.eval()
    return nets


def verify(shared: Path, model_dir: Path, tol: float) -> float:
    """Max |torch - onnxruntime| embedding difference on real held-out crops; raises SystemExit above tol."""
    val = validation_set(shared, SEED)
    o = (RAW - INPUT_SIZE) // 2
    raw = [c[o : o + INPUT_SIZE, o : o + INPUT_SIZE].astype(np.float32) for crops in val.values()
           for c in crops[:6]]
    nets = load_from_onnx(model_dir)
    fam = SiameseFamily(model_dir)
    with torch.no_grad():
        ref = [net(x).numpy() for net, x in zip(nets, inputs(np.stack([standardise(p) for p in raw])))]
    whole, parts = fam.embed_patches(raw)  # standardises inside, as at run time
    diff = max(float(np.abs(whole - ref[0]).max()),
               *(float(np.abs(parts[:, q] - ref[1 + q]).max()) for q in range(4)))
    print(f"verify: {len(raw)} crops, max |torch - onnxruntime| = {diff:.2e} (tolerance {tol:.0e})")
    if diff > tol:
        raise SystemExit(1)
    return diff


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shared", type=Path, default=REPO.parent / "shared")
    ap.add_argument("--out", type=Path, default=MODELS_DIR)
    ap.add_argument("--steps", type=int, default=500)
    ap.add_argument("--batch", type=int, default=32, help="pairs per step")
    ap.add_argument("--verify", action="store_true", help="compare onnxruntime and torch embeddings")
    ap.add_argument("--tol", type=float, default=1e-4)
    args = ap.parse_args(argv)
    if args.verify:
        verify(args.shared, args.out, args.tol)
        return 0
    meta = train(args.shared, args.out, args.steps, args.batch)
    print(json.dumps(meta["validation_pair_accuracy"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
