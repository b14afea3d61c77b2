"""A GIF made small enough for the docs: every k-th frame, scaled, on one shared palette.

IR-SIM's animations (``dsmpepc irsim WORLD --gif``) draw every lidar beam and run 2-4 MB; the
docs keep them at about a sixth of that::

    python tools/dev/shrink_gif.py OUT/corridor-ds-mpepc-nlp-oracle-seed0.gif \\
        docs/figures/irsim-corridor.gif --every 3 --scale 0.5 --colors 48
"""

from __future__ import annotations

import argparse
import os

from PIL import Image, ImageSequence


def shrink(source, target, every: int = 3, scale: float = 0.5, colors: int = 48,
           frame_time: float = 0.2) -> int:
    """Write ``target`` from ``source``; its size in bytes. Each kept frame lasts as long as
    the ``every`` frames it stands for, at ``frame_time`` seconds a frame (a plan's 0.2 s:
    the GIF plays in real time)."""
    image = Image.open(source)
    frames, durations = [], []
    for i, frame in enumerate(ImageSequence.Iterator(image)):
        if i % every:
            continue
        rgb = frame.convert("RGB")
        size = (max(1, round(rgb.width * scale)), max(1, round(rgb.height * scale)))
        frames.append(rgb.resize(size, Image.LANCZOS))
        durations.append(round(frame_time * 1000 * every))
    palette = frames[len(frames) // 2].quantize(colors=colors, method=Image.Quantize.FASTOCTREE)
    small = [f.quantize(palette=palette, dither=Image.Dither.NONE) for f in frames]
    small[0].save(target, save_all=True, append_images=small[1:], duration=durations, loop=0,
                  optimize=True)
    return os.path.getsize(target)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("source")
    parser.add_argument("target")
    parser.add_argument("--every", type=int, default=3)
    parser.add_argument("--scale", type=float, default=0.5)
    parser.add_argument("--colors", type=int, default=48)
    parser.add_argument("--frame-time", type=float, default=0.2)
    args = parser.parse_args(argv)
    print(shrink(args.source, args.target, args.every, args.scale, args.colors,
                 args.frame_time))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
