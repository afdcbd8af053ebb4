#!/usr/bin/python3
"""Trains the monocular surface-normal network of doc/normals_network.md and exports it to ONNX.

Maintainer tool: CI and the README never run it. Needs PyTorch, NumPy and Pillow for the system Python
(Debian 12: `apt-get install -y python3-torch python3-numpy python3-pil`); run it with /usr/bin/python3.
Usually started through scripts/train-normals.sh, which also renders the data.

Data: the train/ and test/ folders of `normals-dataset` (image + normal + mask PNG triples, see
apps/normals-dataset). The network sees 3-channel input as OpenCV's blobFromImage gives it
((pixel - 127.5) / 255, RGB), turns it into luminance and standardizes it per image (so exposure gain and offset
do not matter), and predicts three channels = camera-frame normal (x right, y down, z forward), not normalized,
at the input resolution. Loss: 1 - cos(angle) over the planar pixels.
"""
import argparse
import json
import os
import random
import sys
import time

try:
    import numpy as np
    import torch
    import torch.nn as nn
    import torch.nn.functional as F
    from PIL import Image, ImageDraw
except ImportError as e:  # pragma: no cover
    sys.exit(f"train_normals.py: {e}. Install Debian's packages: apt-get install -y python3-torch python3-numpy "
             "python3-pil, and run with /usr/bin/python3")


# ----------------------------------------------------------------------------------------------------- data
def load_split(folder, limit=0):
    """Images (N,H,W) uint8, normals (N,3,H,W) float32 unit camera-frame, masks (N,H,W) bool, stems."""
    manifest = os.path.join(folder, "manifest.csv")
    if not os.path.isfile(manifest):
        sys.exit(f"train_normals.py: {manifest}: not found (render the data with normals-dataset first)")
    with open(manifest) as f:
        header = f.readline().strip().split(",")
        rows = [dict(zip(header, line.strip().split(","))) for line in f if line.strip()]
    if limit:
        rows = rows[:limit]
    imgs, nrms, masks = [], [], []
    for r in rows:
        stem = os.path.join(folder, r["stem"])
        imgs.append(np.asarray(Image.open(stem + "_image.png").convert("L"), dtype=np.uint8))
        # PNG written by OpenCV: file (R, G, B) = OpenCV channels (2, 1, 0) = encoded (z, y, x).
        enc = np.asarray(Image.open(stem + "_normal.png").convert("RGB"), dtype=np.uint8)[:, :, ::-1]
        nrms.append(np.ascontiguousarray(enc.transpose(2, 0, 1)))
        masks.append(np.asarray(Image.open(stem + "_mask.png"), dtype=np.uint8) > 0)
    normals = np.stack(nrms).astype(np.float32) / 255.0 * 2.0 - 1.0
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-6)
    return np.stack(imgs), normals, np.stack(masks), rows


# ---------------------------------------------------------------------------------------------------- model
def cbr(cin, cout, stride=1):
    return nn.Sequential(nn.Conv2d(cin, cout, 3, stride, 1, bias=False), nn.BatchNorm2d(cout), nn.ReLU(inplace=True))


class NormalNet(nn.Module):
    """U-Net-like encoder-decoder: 4 stride-2 stages (input / 16 at the bottleneck), skip connections."""

    def __init__(self, widths=(16, 32, 64, 96)):
        super().__init__()
        c1, c2, c3, c4 = widths
        # Fixed luminance of the RGB blob (ITU-R BT.601), then per-image standardization.
        self.grey = nn.Conv2d(3, 1, 1, bias=False)
        self.grey.weight.data[:] = torch.tensor([0.299, 0.587, 0.114]).view(1, 3, 1, 1)
        self.grey.weight.requires_grad_(False)
        self.norm = nn.InstanceNorm2d(1, affine=False, eps=1e-3)
        self.e1 = nn.Sequential(cbr(1, c1, 2), cbr(c1, c1))
        self.e2 = nn.Sequential(cbr(c1, c2, 2), cbr(c2, c2))
        self.e3 = nn.Sequential(cbr(c2, c3, 2), cbr(c3, c3))
        self.e4 = nn.Sequential(cbr(c3, c4, 2), cbr(c4, c4), cbr(c4, c4))
        self.d3 = nn.Sequential(cbr(c4 + c3, c3), cbr(c3, c3))
        self.d2 = nn.Sequential(cbr(c3 + c2, c2), cbr(c2, c2))
        self.d1 = nn.Sequential(cbr(c2 + c1, c1), cbr(c1, c1))
        self.head = nn.Conv2d(c1, 3, 3, 1, 1)

    @staticmethod
    def up(t):
        return F.interpolate(t, scale_factor=2.0, mode="bilinear", align_corners=False)

    def forward(self, x):
        x = self.norm(self.grey(x))
        e1 = self.e1(x)
        e2 = self.e2(e1)
        e3 = self.e3(e2)
        e4 = self.e4(e3)
        d3 = self.d3(torch.cat([self.up(e4), e3], 1))
        d2 = self.d2(torch.cat([self.up(d3), e2], 1))
        d1 = self.d1(torch.cat([self.up(d2), e1], 1))
        return self.up(self.head(d1))


def to_blob(grey_u8):
    """(N,H,W) uint8 grey -> (N,3,H,W) float as blobFromImage(scale 1/255, mean 127.5) gives it."""
    x = (torch.from_numpy(grey_u8).float() - 127.5) / 255.0
    return x.unsqueeze(1).expand(-1, 3, -1, -1).contiguous()


def angular_errors_deg(pred, gt, mask):
    p = F.normalize(pred, dim=1)
    cos = (p * gt).sum(1).clamp(-1.0, 1.0)
    return torch.rad2deg(torch.acos(cos))[mask]


def metrics(errs):
    e = errs.double()
    n = e.numel()
    if n == 0:
        return {"count": 0}
    return {"count": int(n), "mean_deg": float(e.mean()), "median_deg": float(e.median()),
            "rmse_deg": float(e.square().mean().sqrt()), "under_11_25": float((e < 11.25).double().mean()),
            "under_22_5": float((e < 22.5).double().mean()), "under_30": float((e < 30).double().mean())}


def evaluate(net, imgs, normals, masks, batch=64):
    net.eval()
    errs = []
    with torch.no_grad():
        for i in range(0, len(imgs), batch):
            pred = net(to_blob(imgs[i:i + batch]))
            errs.append(angular_errors_deg(pred, torch.from_numpy(normals[i:i + batch]),
                                           torch.from_numpy(masks[i:i + batch])))
    return metrics(torch.cat(errs))


# ----------------------------------------------------------------------------------------------------- plot
def plot_curves(path, history):
    """Small PNG: training loss and held-out median error per epoch (two panels)."""
    W, H, pad = 900, 340, 50
    img = Image.new("RGB", (W, H), "white")
    d = ImageDraw.Draw(img)
    panels = [("training loss (1 - cos), per epoch", [h["train_loss"] for h in history], (200, 30, 30)),
              ("held-out median angular error [deg]", [h["test"]["median_deg"] for h in history], (30, 60, 200))]
    pw = (W - 3 * pad) // 2
    for k, (title, ys, colour) in enumerate(panels):
        x0, y0, x1, y1 = pad + k * (pw + pad), pad, pad + k * (pw + pad) + pw, H - pad
        d.rectangle([x0, y0, x1, y1], outline="black")
        d.text((x0, y0 - 18), title, fill="black")
        lo, hi = min(ys), max(ys)
        if hi - lo < 1e-9:
            hi = lo + 1.0
        lo, hi = lo - 0.05 * (hi - lo), hi + 0.05 * (hi - lo)
        for j in range(5):
            v = lo + (hi - lo) * j / 4
            yy = y1 - (y1 - y0) * j / 4
            d.line([x0 - 4, yy, x0, yy], fill="black")
            d.text((x0 - 46, yy - 6), f"{v:.3g}", fill="black")
        n = len(ys)
        pts = [(x0 + (x1 - x0) * (i / max(n - 1, 1)), y1 - (y1 - y0) * (y - lo) / (hi - lo)) for i, y in enumerate(ys)]
        if len(pts) > 1:
            d.line(pts, fill=colour, width=2)
        for p in pts:
            d.ellipse([p[0] - 3, p[1] - 3, p[0] + 3, p[1] + 3], fill=colour)
        d.text((x0, y1 + 8), "epoch 1", fill="black")
        d.text((x1 - 50, y1 + 8), f"epoch {n}", fill="black")
    img.save(path)


# ------------------------------------------------------------------------------------------------------ main
def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", required=True, help="normals-dataset output folder (train/, test/)")
    ap.add_argument("--out", required=True, help="output folder: model.onnx, training.json, loss.png, model.pt")
    ap.add_argument("--epochs", type=int, default=8)
    ap.add_argument("--batch", type=int, default=16)
    ap.add_argument("--lr", type=float, default=2e-3)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--threads", type=int, default=1, help="torch threads (the machine is shared: 1)")
    ap.add_argument("--limit", type=int, default=0, help="use only the first N training views (smoke runs)")
    ap.add_argument("--opset", type=int, default=11)
    a = ap.parse_args()

    torch.set_num_threads(a.threads)
    random.seed(a.seed)
    np.random.seed(a.seed)
    torch.manual_seed(a.seed)
    torch.use_deterministic_algorithms(True)
    os.makedirs(a.out, exist_ok=True)

    t0 = time.time()
    tr_img, tr_n, tr_m, _ = load_split(os.path.join(a.data, "train"), a.limit)
    te_img, te_n, te_m, te_rows = load_split(os.path.join(a.data, "test"))
    H, W = tr_img.shape[1:]
    print(f"data: {len(tr_img)} train, {len(te_img)} held-out views of {W}x{H} ({time.time() - t0:.1f} s)", flush=True)

    net = NormalNet()
    params = sum(p.numel() for p in net.parameters() if p.requires_grad)
    print(f"model: {params} trainable parameters", flush=True)
    opt = torch.optim.AdamW([p for p in net.parameters() if p.requires_grad], lr=a.lr, weight_decay=1e-4)
    steps_per_epoch = len(tr_img) // a.batch
    total_steps = steps_per_epoch * a.epochs
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=a.lr, total_steps=total_steps, pct_start=0.1)
    gen = np.random.default_rng(a.seed)
    history = []
    t_train = time.time()
    step = 0
    for epoch in range(1, a.epochs + 1):
        net.train()
        order = gen.permutation(len(tr_img))
        loss_sum, t_ep = 0.0, time.time()
        for b in range(steps_per_epoch):
            idx = np.sort(order[b * a.batch:(b + 1) * a.batch])
            img, nrm, msk = tr_img[idx], tr_n[idx].copy(), tr_m[idx]
            # Augmentation: horizontal flip (x of the normal changes sign), contrast/brightness jitter.
            flip = gen.random(len(idx)) < 0.5
            img = img.copy()
            img[flip] = img[flip][:, :, ::-1]
            nrm[flip] = nrm[flip][:, :, :, ::-1]
            nrm[flip, 0] *= -1.0
            msk = msk.copy()
            msk[flip] = msk[flip][:, :, ::-1]
            x = to_blob(img)
            gain = torch.from_numpy(gen.uniform(0.7, 1.3, (len(idx), 1, 1, 1)).astype(np.float32))
            bias = torch.from_numpy(gen.uniform(-0.1, 0.1, (len(idx), 1, 1, 1)).astype(np.float32))
            x = (x * gain + bias).clamp(-0.5, 0.5)
            gt = torch.from_numpy(np.ascontiguousarray(nrm))
            m = torch.from_numpy(np.ascontiguousarray(msk))
            pred = F.normalize(net(x), dim=1)
            cos = (pred * gt).sum(1)
            loss = (1.0 - cos)[m].mean()
            opt.zero_grad()
            loss.backward()
            opt.step()
            sched.step()
            step += 1
            loss_sum += float(loss)
            if b % 50 == 0 or b == steps_per_epoch - 1:
                el = time.time() - t_train
                eta = el / step * (total_steps - step)
                print(f"epoch {epoch}/{a.epochs} step {b + 1}/{steps_per_epoch} loss {loss_sum / (b + 1):.4f} "
                      f"({el / 60:.1f} min, ~{eta / 60:.1f} min left)", flush=True)
        test = evaluate(net, te_img, te_n, te_m)
        history.append({"epoch": epoch, "train_loss": loss_sum / steps_per_epoch, "test": test,
                        "epoch_seconds": time.time() - t_ep})
        print(f"epoch {epoch}: train loss {loss_sum / steps_per_epoch:.4f}; held-out mean {test['mean_deg']:.2f} "
              f"median {test['median_deg']:.2f} deg, <11.25 {100 * test['under_11_25']:.1f} %, "
              f"<22.5 {100 * test['under_22_5']:.1f} %, <30 {100 * test['under_30']:.1f} %", flush=True)

    train_seconds = time.time() - t_train
    per_scenario = {}
    for sc in sorted({r["scenario"] for r in te_rows}):
        sel = np.array([r["scenario"] == sc for r in te_rows])
        per_scenario[sc] = evaluate(net, te_img[sel], te_n[sel], te_m[sel])
    torch.save(net.state_dict(), os.path.join(a.out, "model.pt"))
    net.eval()
    onnx_path = os.path.join(a.out, "model.onnx")
    torch.onnx.export(net, to_blob(te_img[:1]), onnx_path, opset_version=a.opset, input_names=["image"],
                      output_names=["normals"], do_constant_folding=True)
    report = {"command": " ".join(sys.argv), "seed": a.seed, "epochs": a.epochs, "batch": a.batch, "lr": a.lr,
              "threads": a.threads, "input": [W, H], "parameters": params, "train_views": len(tr_img),
              "test_views": len(te_img), "train_seconds": train_seconds, "torch": torch.__version__,
              "opset": a.opset, "history": history, "test_final": history[-1]["test"] if history else None,
              "test_per_scenario": per_scenario}
    with open(os.path.join(a.out, "training.json"), "w") as f:
        json.dump(report, f, indent=2)
    plot_curves(os.path.join(a.out, "loss.png"), history)
    print(f"done in {train_seconds / 60:.1f} min: {onnx_path} ({os.path.getsize(onnx_path) / 1e6:.2f} MB)", flush=True)
    for sc, m in per_scenario.items():
        print(f"  held-out {sc}: median {m['median_deg']:.2f} deg, <11.25 {100 * m['under_11_25']:.1f} %")


if __name__ == "__main__":
    main()
