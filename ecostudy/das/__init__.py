"""Feature: driver advice (DAS): rounding, phases, mode choice by MINLP. Uses layers 0-3 only."""
