"""Trajectories: a pose stream cut into stored chunks, their metrics, documents and JSON lines.

A *trajectory* is one uninterrupted pose stream of one walker (one ``uuid``). It is stored as
*chunks*, each a human_trajectory ``Trajectory`` message (the human_trajectory package's format):

* :class:`Chunker` closes a chunk every ``period`` seconds of stamp time (``split="period"``),
  or when the pose enters another region (``split="region"``; ``period`` then also closes a
  long stay, 0 turns that off), and whenever a chunk reaches ``max_poses`` (a MongoDB
  document holds 16 MB; the seed skipped trajectories over 100,000 poses: here they are
  split, never dropped). ``sequence_id`` counts the chunks of a trajectory from 0.
* Consecutive chunks share the boundary pose: the pose that closes a chunk is its last pose
  and the first pose of the next one, so joining the chunks (:func:`join_chunks`) gives back
  the stream exactly and a stored trajectory is continuous.
* The trajectory ends (its last chunk gets ``complete = True``) when the recorder stops
  (:meth:`Chunker.finish`), when no pose came for ``max_gap`` seconds, or when stamps jump
  backwards (a restarted simulation or a replayed bag); the next pose starts a new uuid.

Metrics, per chunk, over the (x, y) positions of its poses (as human_trajectory computes
them): ``trajectory_length`` = the sum of the distances between consecutive poses
(``math.fsum``, so exact to rounding), ``trajectory_displacement`` = the distance from the first
to the last pose, ``displacement_pose_ratio`` = displacement / number of poses.

A pose is a plain tuple ``(t_ns, x, y, z, qx, qy, qz, qw)``: the stamp in integer nanoseconds
(exact, as ROS keeps it) and the pose in the map frame. Documents are mongodb_store's layout of
the message (:func:`chunk_fields`, :func:`chunk_from_document`); the command-line export is one
JSON line per chunk (:func:`chunk_to_json`, :func:`chunk_from_json`) with times as decimal
seconds with 9 digits: times, positions and metrics survive export -> import exactly, the
heading as a planar quaternion (to about 1e-15 rad).

Reading (:func:`trajectory_heads`, :func:`iter_documents`, :func:`select_chunks`) goes
trajectory by trajectory through indexed lookups (:func:`ensure_indexes`), a few chunks at a
time, so memory stays bounded however much is stored.

No rospy here: the ROS glue turns PoseStamped messages into pose tuples.
"""
from __future__ import annotations

from .chunks import (Pose, SPLITS, DEFAULT_PERIOD, DEFAULT_MAX_POSES, DEFAULT_MAX_GAP, TrajectoryError,
                     Chunk, Joined, Chunker, RegionLocator, path_length, displacement, yaw_of,
                     pose_from_xy_yaw, split_poses, join_chunks)
from .documents import (DATABASE, COLLECTION, STORED_TYPE, INDEXES, MAX_CHUNK_BYTES,
                        check_max_poses, max_poses_within, chunk_fields, chunk_id,
                        chunk_from_document, chunk_to_json, chunk_from_json, format_time,
                        parse_time, ensure_indexes, Head, trajectory_heads, iter_documents,
                        document_to_json, select_chunks, stored_people, KINDS, Persons)

__all__ = ["DATABASE", "COLLECTION", "STORED_TYPE", "SPLITS", "DEFAULT_PERIOD",
           "DEFAULT_MAX_POSES", "DEFAULT_MAX_GAP", "INDEXES", "Pose", "TrajectoryError", "Chunk",
           "Joined", "Chunker", "RegionLocator", "path_length", "displacement", "yaw_of",
           "pose_from_xy_yaw", "split_poses", "join_chunks", "chunk_fields", "chunk_id",
           "chunk_from_document", "chunk_to_json", "chunk_from_json", "format_time", "parse_time",
           "ensure_indexes", "Head", "trajectory_heads", "iter_documents", "document_to_json",
           "select_chunks", "stored_people", "KINDS", "Persons", "MAX_CHUNK_BYTES",
           "check_max_poses", "max_poses_within"]
