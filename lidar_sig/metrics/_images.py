"""The metrics and pictures of images (docs/method.md, "Metrics"): s_SSIM of Sg, and the colour
histogram of Sas that d_BD-Img and d_EMD-Img compare. Through OpenCV, imported on first use so that
computing saliency alone never loads it; tests check it against the numpy, scipy and
scikit-image definitions."""
from __future__ import annotations

import numpy as np

from ..method.signature_raster import to_uint8


def ssim(img_a, img_b, mask=None, *, sigma=1.5, k1=0.01, k2=0.03, data_range=1.0):
    """s_SSIM: mean structural similarity of two grayscale images over ``mask`` (docs/method.md, "Metrics").

    Wang et al. (2004) with a Gaussian window (sigma 1.5 px, truncated at 3.5 sigma as
    scikit-image does), population covariances, K1 0.01, K2 0.03. In [-1, 1]; 1 = identical.
    """
    a = np.asarray(img_a, dtype=np.float64)
    b = np.asarray(img_b, dtype=np.float64)
    if a.shape != b.shape:
        raise ValueError(f"images differ in shape: {a.shape} and {b.shape}")

    def blur(x):
        return gaussian_blur(x, sigma, truncate=3.5)

    mu_a, mu_b = blur(a), blur(b)
    var_a = blur(a * a) - mu_a * mu_a
    var_b = blur(b * b) - mu_b * mu_b
    cov = blur(a * b) - mu_a * mu_b
    c1, c2 = (k1 * data_range) ** 2, (k2 * data_range) ** 2
    s = ((2 * mu_a * mu_b + c1) * (2 * cov + c2)) / ((mu_a ** 2 + mu_b ** 2 + c1) * (var_a + var_b + c2))
    return float(s[mask].mean() if mask is not None else s.mean())


def gaussian_blur(image, sigma, *, truncate=3.5):
    """A 2-D float image convolved with a Gaussian of standard deviation ``sigma`` pixels,
    cut at ``truncate`` sigma, edges mirrored (d c b a | a b c d): scipy's
    ``gaussian_filter(image, sigma, truncate=truncate, mode="reflect")``, computed by OpenCV."""
    import cv2

    radius = int(truncate * sigma + 0.5)  # scipy's rule, so both use the same window
    size = 2 * radius + 1
    return cv2.GaussianBlur(np.asarray(image, dtype=np.float64), (size, size), sigmaX=sigma, sigmaY=sigma,
                            borderType=cv2.BORDER_REFLECT)


def color_histogram(rgb, mask=None, *, bins=8):
    """Normalized 3-D colour histogram (bins per channel, R major) of an RGB image in [0, 1].

    The image is first quantized to 8 bits as stored in PNG; bin = value * bins // 256
    (OpenCV's calcHist over [0, 256)).
    """
    import cv2

    px = to_uint8(rgb)
    m = None if mask is None else np.asarray(mask, dtype=np.uint8)
    hist = cv2.calcHist([px], [0, 1, 2], m, [bins] * 3, [0, 256] * 3).ravel().astype(np.float64)
    return hist / max(hist.sum(), 1.0)
