"""Small representative NPU-stage modules used by the quantize tests."""

import torch
import torch.nn as nn
import torch.nn.functional as F


class Recon(nn.Module):
    """PixelUnshuffle -> conv -> relu -> conv -> cat(skip) -> conv -> PixelShuffle -> add residual -> clamp.

    Inputs: history (N, 3, H, W) at HR and the anti-aliased LR frame (N, 3, H/2, W/2).
    """

    def __init__(self, channels: int = 16, scale: int = 2):
        super().__init__()
        self.down = nn.PixelUnshuffle(scale)
        self.head = nn.Conv2d(3 * scale * scale + 3, channels, 3, padding=1)
        self.body = nn.Conv2d(channels, channels, 3, padding=1)
        self.dw = nn.Conv2d(channels, channels, 3, padding=1, groups=channels)
        self.fuse = nn.Conv2d(2 * channels, channels, 1)
        self.tail = nn.Conv2d(channels, 3 * scale * scale, 3, padding=1)
        self.up = nn.PixelShuffle(scale)

    def forward(self, history, aa):
        x = torch.cat([self.down(history), aa], dim=1)
        skip = F.relu(self.head(x))
        y = F.relu(self.body(skip))
        y = F.relu(self.dw(y))
        y = self.fuse(torch.cat([y, skip], dim=1))
        y = self.up(self.tail(y))
        return torch.clamp(y + history, 0.0, 1.0)


class Gates(nn.Module):
    """Sigmoid / tanh gates, average pooling (VALID and SAME), bilinear resize, a stride-2 conv, multiplication."""

    def __init__(self, channels: int = 8):
        super().__init__()
        self.a = nn.Conv2d(3, channels, 3, padding=1)
        self.down = nn.Conv2d(channels, channels, 3, stride=2, padding=1)
        self.pool = nn.AvgPool2d(2)
        self.smooth = nn.AvgPool2d(3, stride=1, padding=1, count_include_pad=False)
        self.g = nn.Conv2d(channels, channels, 1)
        self.t = nn.Conv2d(channels, channels, 1)
        self.out = nn.Conv2d(channels, 3, 3, padding=1)

    def forward(self, x):
        a = F.relu(self.a(x))
        d = F.relu(self.down(a))
        p = self.pool(self.smooth(a))
        m = torch.sigmoid(self.g(d)) * torch.tanh(self.t(p))
        u = F.interpolate(m, scale_factor=2, mode="bilinear", align_corners=False)
        return self.out(u) + x


def make(name: str, seed: int = 0) -> nn.Module:
    torch.manual_seed(seed)
    return {"recon": Recon, "gates": Gates}[name]().eval()


def example_inputs(name: str, n: int = 1, size: int = 16, seed: int = 0):
    g = torch.Generator().manual_seed(seed)
    if name == "recon":
        return [torch.rand(n, 3, size, size, generator=g), torch.rand(n, 3, size // 2, size // 2, generator=g)]
    return [torch.rand(n, 3, size, size, generator=g)]
