"""Figures and videos: the paper's plots from traces and metrics (`plots`, needs matplotlib) and
mp4 rendering (`video`)."""
