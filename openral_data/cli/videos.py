"""`openral-data videos reencode|encode-images`: thin typer wrappers over `edit.videos`."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from openral_data import paths
from openral_data.cli import encoder_flags as flags
from openral_data.cli.edit import report
from openral_data.cli.takes import takes
from openral_data.formats.codec import Codec
from openral_data.formats.repo_id import resolve_dataset

videos_app = typer.Typer(
    no_args_is_help=True,
    help="Re-encode a dataset's video cameras, or turn its image features into videos (written to a new dataset).",
)

_CAMERA_HELP = (
    "a camera to encode (feature key, or camera name: wrist for observation.images.wrist); repeat; default all"
)


@videos_app.command("reencode")
@takes("dataset", pixels=True, v2="upgrade", writes="new or in place")
def reencode_cmd(
    dataset: Annotated[Path, typer.Argument(help="a LeRobot v3 dataset (ours or lerobot's)")],
    codec: Annotated[Codec, typer.Option("--vcodec", "--codec", help=flags.VCODEC_HELP)],
    size: Annotated[str | None, typer.Option(help="resize the cameras encoded to WIDTHxHEIGHT, e.g. 320x240")] = None,
    camera: Annotated[list[str] | None, typer.Option(help=_CAMERA_HELP)] = None,
    out: Annotated[Path | None, typer.Option(help="new dataset folder (must not exist or be empty)")] = None,
    in_place: Annotated[bool, typer.Option(help="replace DATASET itself (swapped in once complete)")] = False,
    crf: flags.CrfFlag = None,
    gop: flags.GopFlag = None,
    preset: flags.PresetFlag = None,
    pix_fmt: flags.PixFmtFlag = None,
    encoder_threads: flags.ThreadsFlag = None,
) -> None:
    """Decode DATASET's video cameras and encode them again with --codec (resized to --size); the cameras not
    chosen are copied packet for packet."""
    from openral_data.edit.videos import reencode

    video = flags.video_settings(codec, crf, gop, preset, pix_fmt, encoder_threads)
    if out is not None:
        paths.check_creatable(out, "--out")
    report("reencoded", [reencode(resolve_dataset(dataset), codec, size, camera or (), out, in_place, video)])


@videos_app.command("encode-images")
@takes("dataset", pixels=True, v2="upgrade", writes="new or in place")
def encode_images_cmd(
    dataset: Annotated[Path, typer.Argument(help="a LeRobot v3 dataset with dtype: image features")],
    camera: Annotated[list[str] | None, typer.Option(help=_CAMERA_HELP)] = None,
    codec: Annotated[Codec, typer.Option("--vcodec", "--codec", help=flags.VCODEC_HELP)] = "av1",
    out: Annotated[Path | None, typer.Option(help="new dataset folder (must not exist or be empty)")] = None,
    in_place: Annotated[bool, typer.Option(help="replace DATASET itself (swapped in once complete)")] = False,
    crf: flags.CrfFlag = None,
    gop: flags.GopFlag = None,
    preset: flags.PresetFlag = None,
    pix_fmt: flags.PixFmtFlag = None,
    encoder_threads: flags.ThreadsFlag = None,
) -> None:
    """Turn DATASET's image features (pictures stored in the data parquet) into video cameras: their column is
    dropped and their frames are encoded into videos/KEY/."""
    from openral_data.edit.videos import encode_images

    video = flags.video_settings(codec, crf, gop, preset, pix_fmt, encoder_threads)
    if out is not None:
        paths.check_creatable(out, "--out")
    report("encoded", [encode_images(resolve_dataset(dataset), camera or (), codec, out, in_place, video)])
