"""Small HDF5 files in the layouts `convert` reads, written with h5py the way each project's own writer writes
them (no data copied from those projects; every value is a function of (episode, step) so tests can recompute it):

* robomimic: ARISE-Initiative/robomimic@v0.3.0:robomimic/scripts/dataset_states_to_obs.py: `data` group with
  attrs `total` and `env_args` (json.dumps of env.serialize(): env_name, type, env_kwargs), one `demo_N` group a
  demo with attr `num_samples` (and `model_file`), datasets `states`, `actions`, `rewards`, `dones`,
  `obs/<key>`, `next_obs/<key>`; plus the `mask` group of filter keys.
* LIBERO: Lifelong-Robot-Learning/LIBERO:scripts/create_dataset.py: as robomimic plus `data` attrs
  `problem_info` (json.dumps with `language_instruction`), `env_name`, `bddl_file_name`, and `robot_states`
  beside `states`; of its obs keys these files hold `agentview_rgb`, `eye_in_hand_rgb`, `joint_states`,
  `gripper_states`, `ee_pos`.
* MimicGen (NVlabs/mimicgen) and Isaac Lab's recorder: robomimic's layout plus per-demo `datagen_info` and
  `initial_state` groups (not per-step arrays).
* ALOHA / ACT: tonyzhaozh/act:record_sim_episodes.py and tonyzhaozh/aloha:aloha_scripts/record_episodes.py: one
  `episode_N.hdf5` a episode, root attrs `sim` (and `compress`), `/observations/qpos`, `/observations/qvel`,
  `/observations/images/<cam>` (T, H, W, 3) uint8 chunked a row (480x640 there, 64x64 here), `/action`, float32
  (h5py's default dtype there); the compressed variant: each image row a JPEG (cv2.imencode there, quality 50;
  Pillow here) zero-padded to the longest, `(T, padded)` uint8, and `/compress_len` (cameras, T).

These writers are ours (h5py, following those files); none of the projects' code or data is copied.
"""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Any

import h5py
import numpy as np
from PIL import Image

SIZE = 64
FPS = 20


def picture(e: int, t: int, c: int = 0) -> np.ndarray[Any, np.dtype[np.uint8]]:
    """A smooth gradient, different per episode, step and camera (checkable after lossy video)."""
    y, x = np.mgrid[0:SIZE, 0:SIZE]
    img = np.stack([x * 3 + t * 5, y * 3 + e * 20, np.full_like(x, 40 + 60 * c + 3 * t)], axis=-1)
    return (img % 256).astype(np.uint8)


def vector(e: int, t: int, width: int, salt: float) -> np.ndarray[Any, np.dtype[np.float64]]:
    return np.array([salt + e + 0.01 * t + 0.125 * i for i in range(width)], np.float64)


def _env_args(env_name: str, sparse: bool | None) -> str:
    kwargs: dict[str, Any] = {"robots": ["Panda"], "control_freq": FPS, "has_renderer": False,
                              "camera_names": ["agentview"]}  # fmt: skip
    if sparse is not None:  # robomimic's and MimicGen's env_args say it; LIBERO's do not
        kwargs["reward_shaping"] = not sparse
    return json.dumps({"env_name": env_name, "type": 1, "env_kwargs": kwargs}, indent=4)


def write_robomimic(
    path: Path, lengths: tuple[int, ...] = (12, 9, 15), *, layout: str = "robomimic", sparse: bool | None = True
) -> Path:
    """robomimic (image obs), LIBERO (`layout="libero"`) or MimicGen (`layout="mimicgen"`); `sparse`: the
    env_args say the reward is sparse (robomimic / MimicGen only; None: they do not say)."""
    libero = layout == "libero"
    with h5py.File(path, "w") as f:
        data = f.create_group("data")
        for e, n in enumerate(lengths):
            ep = data.create_group(f"demo_{e}")
            ep.attrs["num_samples"] = n
            ep.attrs["model_file"] = "<mujoco/>"
            ts = range(n)
            obs: dict[str, Any]
            if libero:
                obs = {
                    "agentview_rgb": np.stack([picture(e, t, 0) for t in ts]),
                    "eye_in_hand_rgb": np.stack([picture(e, t, 1) for t in ts]),
                    "joint_states": np.stack([vector(e, t, 7, 1.0) for t in ts]),
                    "gripper_states": np.stack([vector(e, t, 2, 2.0) for t in ts]),
                    "ee_pos": np.stack([vector(e, t, 3, 3.0) for t in ts]),
                }
            else:
                obs = {
                    "agentview_image": np.stack([picture(e, t, 0) for t in ts]),
                    "robot0_eef_pos": np.stack([vector(e, t, 3, 1.0) for t in ts]),
                    "robot0_gripper_qpos": np.stack([vector(e, t, 2, 2.0) for t in ts]),
                    "object": np.stack([vector(e, t, 10, 5.0) for t in ts]),
                }
            for k, v in obs.items():
                ep.create_dataset(f"obs/{k}", data=v, compression="gzip" if v.dtype == np.uint8 else None)
                ep.create_dataset(f"next_obs/{k}", data=np.concatenate([v[1:], v[-1:]]))
            ep.create_dataset("actions", data=np.stack([vector(e, t, 7, -1.0) for t in ts]))
            ep.create_dataset("states", data=np.stack([vector(e, t, 32, 9.0) for t in ts]))
            rewards = np.zeros(n, np.float64)
            dones = np.zeros(n, np.int64)
            dones[-1] = 1  # robomimic's done_mode 2: the end of every demo (and every success)
            if e != 1:  # demo 1 never succeeds (sparse reward: 1 where the task is done)
                rewards[-1] = 1.0
            ep.create_dataset("rewards", data=rewards)
            ep.create_dataset("dones", data=dones)
            if libero:
                ep.create_dataset("robot_states", data=np.stack([vector(e, t, 9, 4.0) for t in ts]))
            if layout == "mimicgen":
                ep.create_dataset("initial_state/states", data=vector(e, 0, 32, 9.0)[None])
                ep.create_dataset("datagen_info/eef_pose", data=np.zeros((n, 4, 4)))
        data.attrs["total"] = sum(lengths)
        data.attrs["env_args"] = _env_args("LIBERO_Kitchen" if libero else "Lift", None if libero else sparse)
        if libero:
            info = {"problem_name": "libero_kitchen_tabletop_manipulation", "domain_name": "robosuite",
                    "language_instruction": "open the top drawer of the cabinet"}  # fmt: skip
            data.attrs["problem_info"] = json.dumps(info)
            data.attrs["env_name"] = "LIBERO_Kitchen"
            data.attrs["bddl_file_name"] = "KITCHEN_SCENE1_open_the_top_drawer_of_the_cabinet.bddl"
        mask = f.create_group("mask")
        mask.create_dataset("train", data=np.array([f"demo_{e}".encode() for e in range(len(lengths))]))
    return path


ALOHA_CAMERAS = ("top", "angle")


def write_aloha(folder: Path, lengths: tuple[int, ...] = (10, 7), *, compress: bool = False) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for e, n in enumerate(lengths):
        images = {cam: [picture(e, t, c) for t in range(n)] for c, cam in enumerate(ALOHA_CAMERAS)}
        with h5py.File(folder / f"episode_{e}.hdf5", "w", rdcc_nbytes=1024**2 * 2) as root:
            root.attrs["sim"] = not compress
            if compress:
                root.attrs["compress"] = True
            obs = root.create_group("observations")
            image = obs.create_group("images")
            if compress:
                encoded = {cam: [_jpeg(img) for img in imgs] for cam, imgs in images.items()}
                padded = max(len(b) for bs in encoded.values() for b in bs)
                for cam, bs in encoded.items():
                    ds = image.create_dataset(cam, (n, padded), dtype="uint8", chunks=(1, padded))
                    for t, b in enumerate(bs):
                        row = np.zeros(padded, np.uint8)
                        row[: len(b)] = np.frombuffer(b, np.uint8)
                        ds[t] = row
                root.create_dataset("compress_len", (len(ALOHA_CAMERAS), n), dtype="f4")
                root["compress_len"][...] = [[len(b) for b in encoded[cam]] for cam in ALOHA_CAMERAS]
            else:
                for cam, imgs in images.items():
                    ds = image.create_dataset(cam, (n, SIZE, SIZE, 3), dtype="uint8", chunks=(1, SIZE, SIZE, 3))
                    ds[...] = np.stack(imgs)
            qpos = obs.create_dataset("qpos", (n, 14), dtype="f4")
            qvel = obs.create_dataset("qvel", (n, 14), dtype="f4")
            action = root.create_dataset("action", (n, 14), dtype="f4")
            qpos[...] = np.stack([vector(e, t, 14, 1.0) for t in range(n)])
            qvel[...] = np.stack([vector(e, t, 14, 2.0) for t in range(n)])
            action[...] = np.stack([vector(e, t, 14, -1.0) for t in range(n)])
    return folder


def _jpeg(img: np.ndarray[Any, np.dtype[np.uint8]]) -> bytes:
    buf = io.BytesIO()
    Image.fromarray(img).save(buf, format="JPEG", quality=50)
    return buf.getvalue()


def decode_jpeg_row(row: np.ndarray[Any, np.dtype[np.uint8]]) -> np.ndarray[Any, np.dtype[np.uint8]]:
    """An independent decode of one padded JPEG row (PIL on the bytes up to the JPEG end marker)."""
    data = row.tobytes()
    end = data.rfind(b"\xff\xd9")
    return np.asarray(Image.open(io.BytesIO(data[: end + 2])).convert("RGB"))
