"""One cloud -> saliency and signature: the Pipeline and its Result."""
