#!/usr/bin/env python3
"""OpenCV oracle for softsense's sRGB -> CIELAB conversion.

Usage: opencv_lab.py IN.bin OUT.bin
  IN.bin:  raw uint8 RGB triples.
  OUT.bin: raw little-endian float32 L a b triples from
           cv2.cvtColor(float32 RGB / 255, cv2.COLOR_RGB2Lab) (OpenCV's float path).
Prints the OpenCV version on stdout. Exit 1 on failure.
"""

import sys

import cv2
import numpy as np


def main():
    if len(sys.argv) != 3:
        print(f"usage: {sys.argv[0]} IN.bin OUT.bin", file=sys.stderr)
        return 2
    rgb = np.fromfile(sys.argv[1], dtype=np.uint8)
    if rgb.size % 3:
        print("input is not a whole number of RGB triples", file=sys.stderr)
        return 1
    img = (rgb.reshape(1, -1, 3).astype(np.float32) / np.float32(255.0))
    out = np.empty((img.shape[1], 3), dtype="<f4")
    step = 1 << 20  # cvtColor on chunks keeps memory modest
    for s in range(0, img.shape[1], step):
        out[s:s + step] = cv2.cvtColor(img[:, s:s + step], cv2.COLOR_RGB2Lab).reshape(-1, 3)
    out.tofile(sys.argv[2])
    print(cv2.__version__)
    return 0


if __name__ == "__main__":
    sys.exit(main())
