"""RLDS / TFDS episodes (the Open X-Embodiment layout): a TFDS build folder of ``features.json``,
``dataset_info.json`` and ``*.tfrecord-NNNNN-of-NNNNN`` shards, one `tf.train.Example` an episode with its
``steps/observation/*``, ``steps/action``, ``steps/language_instruction``, ``steps/is_first|is_last|is_terminal``,
``steps/reward``, ``steps/discount`` lists and its ``episode_metadata/*``. Read without TensorFlow (TFRecord
framing and the Example message in `tfrecord`, the feature tree in `features`) as an `ArraySource` (layout
``rlds``; RLDS stores no step rate, so `fps` is None and the mapping gives it).
"""

from openral_data.formats.rlds.reader import RldsEpisode, RldsSource, detect

__all__ = ["RldsEpisode", "RldsSource", "detect"]
